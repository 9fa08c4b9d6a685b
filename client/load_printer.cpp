#include "client/load_printer.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/response_printer.hpp"
#include "client/table.hpp"

namespace soilvol::client {
namespace {

std::string State(const v1::Load& load) {
    const std::string state = EnumLabel(v1::LoadState_Name(load.state()), "LOAD_STATE_");
    if (load.state() != v1::LOAD_STATE_CLOSED) return state;
    return absl::StrCat(
        state, " (", EnumLabel(v1::LoadCloseReason_Name(load.close_reason()), "LOAD_CLOSE_REASON_"),
        ")");
}

/// "loaded_ok (p 0.93)".
std::string Status(const v1::Load& load) {
    return absl::StrFormat(
        "%s (p %.2f)", EnumLabel(v1::LoadStatus_Name(load.assessment().status()), "LOAD_STATUS_"),
        load.assessment().status_probability());
}

std::string Mass(const v1::Load& load) {
    if (!load.has_mass_kg()) return "-";
    return absl::StrFormat("%.0f +- %.0f kg", load.mass_kg(), load.mass_uncertainty_kg());
}

std::string Reconciled(const v1::Load& load) {
    if (!load.has_reconciliation()) return "-";
    const v1::LoadReconciliation& r = load.reconciliation();
    return absl::StrFormat("%s: body %.3f m^3, difference %+.3f m^3 = %.1f sigma (%s)",
                           r.estimate_id(), r.body_volume_m3(), r.difference_m3(),
                           r.difference_sigmas(), r.within_two_sigma() ? "agree" : "DISAGREE");
}

}  // namespace

void PrintLoad(const v1::Load& load, bool json, std::ostream& out) {
    if (json) return PrintJson(load, out);
    PrintFields({{"load", load.load_id()},
                 {"haul unit", load.haul_unit_id()},
                 {"body", load.body_container_id().empty() ? "-" : load.body_container_id()},
                 {"state", State(load)},
                 {"passes", absl::StrCat(load.pass_count())},
                 {"volume", absl::StrFormat("%.3f +- %.3f m^3 (bank %.3f m^3)", load.volume_m3(),
                                            load.uncertainty_m3(), load.bank_volume_m3())},
                 {"mass", Mass(load)},
                 {"status", Status(load)},
                 {"mean cycle", absl::StrFormat("%.1f s", load.mean_cycle_seconds())},
                 {"body scan", Reconciled(load)},
                 {"created", TimeText(load.create_time())},
                 {"closed", TimeText(load.close_time())},
                 {"etag", load.etag()}},
                out);
    if (load.passes_size() == 0) return;
    Table passes({"pass", "container", "estimate", "volume [m^3]", "1-sigma [L]", "time"});
    int n = 0;
    for (const v1::LoadPass& pass : load.passes()) {
        passes.AddRow({absl::StrCat(++n), pass.container_id(), pass.estimate_id(),
                       Fixed(pass.volume_m3(), 4), Fixed(1000.0 * pass.uncertainty_m3(), 1),
                       TimeText(pass.create_time())});
    }
    passes.Print(out);
}

void PrintLoadEventLine(const v1::LoadEvent& event, bool json, std::ostream& out) {
    if (json) {
        PrintJson(event, out);
        out.flush();  // a watch: each event as it arrives
        return;
    }
    const v1::Load& load = event.load();
    out << event.event_id() << "  " << TimeText(event.time()) << "  "
        << EnumLabel(v1::LoadEventKind_Name(event.kind()), "LOAD_EVENT_KIND_") << "  "
        << load.load_id() << "  " << load.haul_unit_id() << "  " << State(load) << "  "
        << load.pass_count() << " passes  " << Fixed(load.volume_m3(), 3) << " m^3" << std::endl;
}

void PrintLoadList(const v1::ListLoadsResponse& list, bool json, std::ostream& out) {
    if (json) return PrintJson(list, out);
    Table table({"load", "haul unit", "state", "passes", "volume [m^3]", "1-sigma [L]", "status",
                 "body scan", "created"});
    for (const v1::Load& load : list.loads()) {
        const std::string body = !load.has_reconciliation()                 ? "-"
                                 : load.reconciliation().within_two_sigma() ? "agrees"
                                                                            : "disagrees";
        table.AddRow({load.load_id(), load.haul_unit_id(), State(load),
                      absl::StrCat(load.pass_count()), Fixed(load.volume_m3(), 3),
                      Fixed(1000.0 * load.uncertainty_m3(), 1), Status(load), body,
                      TimeText(load.create_time())});
    }
    table.Print(out);
}

}  // namespace soilvol::client
