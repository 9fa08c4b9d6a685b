#include "client/demo_table.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/table.hpp"

namespace soilvol::client {
namespace {

std::string JsonString(const std::string& text) {
    std::string out = "\"";
    for (const char c : text) {
        if (c == '"' || c == '\\') {
            absl::StrAppend(&out, "\\", std::string(1, c));
        } else if (static_cast<unsigned char>(c) < 0x20) {
            absl::StrAppendFormat(&out, "\\u%04x", static_cast<int>(c));
        } else {
            out += c;
        }
    }
    return out + "\"";
}

std::string JsonRow(const DemoRow& row) {
    const double true_l = row.true_volume_m3 * kLitre;
    std::string out = absl::StrFormat("{\"fill\":%g,\"trueL\":%.3f", row.fill_share, true_l);
    if (!row.estimate) {
        absl::StrAppend(&out, ",\"error\":", JsonString(row.error));
    } else {
        const double measured_l = row.estimate->volume_m3() * kLitre;
        absl::StrAppendFormat(
            &out,
            ",\"measuredL\":%.3f,\"errorL\":%.3f,\"errorPctStruck\":%.4f,\"uncertaintyL\":%.3f,"
            "\"serverMs\":%.3f",
            measured_l, measured_l - true_l,
            100 * (measured_l - true_l) / (row.struck_capacity_m3 * kLitre),
            row.estimate->uncertainty_m3() * kLitre, row.estimate->timings().total_ms());
    }
    return out + absl::StrFormat(",\"roundTripMs\":%.3f}", row.round_trip_ms);
}

}  // namespace

void PrintDemoRows(const std::vector<DemoRow>& rows, bool json, std::ostream& out) {
    if (json) {
        std::vector<std::string> objects;
        for (const DemoRow& row : rows) objects.push_back(JsonRow(row));
        out << "[" << absl::StrJoin(objects, ",") << "]\n";
        return;
    }
    Table table({"fill [% depth]", "true [L]", "measured [L]", "error [L]", "error [% struck]",
                 "uncertainty [L]", "server [ms]", "round trip [ms]"});
    for (const DemoRow& row : rows) {
        const double true_l = row.true_volume_m3 * kLitre;
        if (!row.estimate) {
            table.AddRow({Fixed(100 * row.fill_share, 0), Fixed(true_l, 1), "-", "-", "-", "-", "-",
                          Fixed(row.round_trip_ms, 1)});
            continue;
        }
        const double measured_l = row.estimate->volume_m3() * kLitre;
        const double error_pct = 100 * (measured_l - true_l) / (row.struck_capacity_m3 * kLitre);
        table.AddRow({Fixed(100 * row.fill_share, 0), Fixed(true_l, 1), Fixed(measured_l, 1),
                      absl::StrFormat("%+.1f", measured_l - true_l),
                      absl::StrFormat("%+.2f", error_pct),
                      Fixed(row.estimate->uncertainty_m3() * kLitre, 1),
                      Fixed(row.estimate->timings().total_ms(), 1), Fixed(row.round_trip_ms, 1)});
    }
    out << "\n";
    table.Print(out);
}

}  // namespace soilvol::client
