#include "server/handlers/export_rows.hpp"

#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/time_util.h>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "core/common/status_macros.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

constexpr std::size_t kChunkBytes = 64 * 1024;
constexpr int kPageSize = 1000;

std::string Time(const google::protobuf::Timestamp& t) {
    return t.seconds() == 0 && t.nanos() == 0 ? std::string() : TimeUtil::ToString(t);
}

std::string Number(double value) { return absl::StrFormat("%.9g", value); }

/// A text cell: quoted when needed, defused when a spreadsheet would evaluate it.
std::string Text(const std::string& value) {
    std::string cell = value;
    if (!cell.empty() && std::string("=+-@\t\r").find(cell.front()) != std::string::npos) {
        cell.insert(cell.begin(), '\'');
    }
    if (cell.find_first_of(",\"\r\n") == std::string::npos) return cell;
    std::string quoted = "\"";
    for (const char c : cell) {
        if (c == '"') quoted += '"';
        quoted += c;
    }
    return quoted + "\"";
}

std::string Enum(const std::string& name, const std::string& prefix) {
    return name.rfind(prefix, 0) == 0 ? name.substr(prefix.size()) : name;
}

constexpr const char* kEstimateColumns[] = {
    "estimate_id",     "container_id", "create_time",        "request_id",
    "registration_id", "load_id",      "load_role",          "volume_m3",
    "uncertainty_m3",  "fill_ratio",   "fill_ratio_heaped",  "bank_volume_m3",
    "mass_kg",         "load_status",  "status_probability", "scan_observed_share",
    "scan_points",     "total_ms"};

std::vector<std::string> EstimateCells(const v1::Estimate& e) {
    const v1::EstimateVolumeResponse& r = e.result();
    return {e.estimate_id(),
            Text(e.container_id()),
            Time(e.create_time()),
            Text(e.request_id()),
            r.registration_id(),
            r.load_id(),
            Enum(v1::LoadRole_Name(r.load_role()), "LOAD_ROLE_"),
            Number(r.volume_m3()),
            Number(r.uncertainty_m3()),
            Number(r.fill_ratio()),
            Number(r.fill_ratio_heaped()),
            Number(r.load().bank_volume_m3()),
            r.has_mass_kg() ? Number(r.mass_kg()) : "",
            Enum(v1::LoadStatus_Name(r.load().status()), "LOAD_STATUS_"),
            Number(r.load().status_probability()),
            Number(r.coverage().scan_observed_share()),
            absl::StrCat(r.scan_points()),
            Number(r.timings().total_ms())};
}

constexpr const char* kLoadColumns[] = {"load_id",
                                        "haul_unit_id",
                                        "body_container_id",
                                        "display_name",
                                        "state",
                                        "close_reason",
                                        "create_time",
                                        "close_time",
                                        "pass_count",
                                        "volume_m3",
                                        "uncertainty_m3",
                                        "bank_volume_m3",
                                        "mass_kg",
                                        "load_status",
                                        "status_probability",
                                        "mean_cycle_seconds",
                                        "body_volume_m3",
                                        "body_difference_m3",
                                        "body_difference_sigmas",
                                        "body_within_two_sigma"};

std::vector<std::string> LoadCells(const v1::Load& l) {
    const bool body = l.has_reconciliation();
    const v1::LoadReconciliation& r = l.reconciliation();
    return {l.load_id(),
            Text(l.haul_unit_id()),
            l.body_container_id(),
            Text(l.display_name()),
            Enum(v1::LoadState_Name(l.state()), "LOAD_STATE_"),
            Enum(v1::LoadCloseReason_Name(l.close_reason()), "LOAD_CLOSE_REASON_"),
            Time(l.create_time()),
            Time(l.close_time()),
            absl::StrCat(l.pass_count()),
            Number(l.volume_m3()),
            Number(l.uncertainty_m3()),
            Number(l.bank_volume_m3()),
            l.has_mass_kg() ? Number(l.mass_kg()) : "",
            Enum(v1::LoadStatus_Name(l.assessment().status()), "LOAD_STATUS_"),
            Number(l.assessment().status_probability()),
            Number(l.mean_cycle_seconds()),
            body ? Number(r.body_volume_m3()) : "",
            body ? Number(r.difference_m3()) : "",
            body ? Number(r.difference_sigmas()) : "",
            body ? (r.within_two_sigma() ? "true" : "false") : ""};
}

constexpr const char* kStatusKeys[] = {"empty",     "carryback",  "underloaded",
                                       "loaded_ok", "overloaded", "loaded"};

std::vector<std::string> ProductionCells(const v1::ProductionRow& p) {
    std::vector<std::string> cells = {Text(p.period()),           Time(p.start_time()),
                                      Time(p.end_time()),         Text(p.group()),
                                      absl::StrCat(p.loads()),    absl::StrCat(p.passes()),
                                      Number(p.volume_m3()),      Number(p.bank_volume_m3()),
                                      Number(p.mass_kg()),        absl::StrCat(p.mass_passes()),
                                      Number(p.mean_fill_ratio())};
    for (const char* key : kStatusKeys) {
        const auto found = p.status_counts().find(key);
        cells.push_back(absl::StrCat(found == p.status_counts().end() ? 0 : found->second));
    }
    return cells;
}

std::string Line(const std::vector<std::string>& cells) {
    return absl::StrCat(absl::StrJoin(cells, ","), "\r\n");
}

/// The response's repeated item field (estimates, loads, rows).
const google::protobuf::FieldDescriptor* ItemsOf(const google::protobuf::Descriptor& response) {
    for (int i = 0; i < response.field_count(); ++i) {
        const google::protobuf::FieldDescriptor* field = response.field(i);
        if (field->is_repeated() &&
            field->type() == google::protobuf::FieldDescriptor::TYPE_MESSAGE) {
            return field;
        }
    }
    return nullptr;
}

}  // namespace

absl::StatusOr<ExportFormat> ParseExportFormat(const std::string& text) {
    if (text == "csv") return ExportFormat::kCsv;
    if (text == "jsonl" || text == "ndjson") return ExportFormat::kJsonLines;
    return absl::InvalidArgumentError(absl::StrCat("format: '", text, "' is none of csv, jsonl"));
}

absl::StatusOr<std::string> CsvHeader(const google::protobuf::Descriptor& item) {
    std::vector<std::string> columns;
    if (&item == v1::Estimate::descriptor()) {
        columns.assign(std::begin(kEstimateColumns), std::end(kEstimateColumns));
    } else if (&item == v1::Load::descriptor()) {
        columns.assign(std::begin(kLoadColumns), std::end(kLoadColumns));
    } else if (&item == v1::ProductionRow::descriptor()) {
        columns = {"period",  "start_time",  "end_time",       "group",
                   "loads",   "passes",      "volume_m3",      "bank_volume_m3",
                   "mass_kg", "mass_passes", "mean_fill_ratio"};
        for (const char* key : kStatusKeys) columns.push_back(absl::StrCat("status_", key));
    } else {
        return absl::InternalError(absl::StrCat("no CSV columns for ", item.full_name()));
    }
    return Line(columns);
}

std::string CsvLine(const google::protobuf::Message& item) {
    if (const auto* e = dynamic_cast<const v1::Estimate*>(&item)) return Line(EstimateCells(*e));
    if (const auto* l = dynamic_cast<const v1::Load*>(&item)) return Line(LoadCells(*l));
    if (const auto* p = dynamic_cast<const v1::ProductionRow*>(&item)) {
        return Line(ProductionCells(*p));
    }
    return "\r\n";
}

absl::Status ExportList(const Rpc& list, google::protobuf::Message& request, ExportFormat format,
                        CallRecord& record, const std::function<bool(std::string)>& write) {
    const google::protobuf::Reflection& in = *request.GetReflection();
    const google::protobuf::Descriptor& request_type = *request.GetDescriptor();
    const auto* page_size = request_type.FindFieldByName("page_size");
    const auto* page_token = request_type.FindFieldByName("page_token");
    std::unique_ptr<google::protobuf::Message> page = list.new_response();
    const auto* items = ItemsOf(*page->GetDescriptor());
    const auto* next = page->GetDescriptor()->FindFieldByName("next_page_token");
    if (page_size == nullptr || page_token == nullptr || items == nullptr || next == nullptr) {
        return absl::InternalError("the export's list has no pages");
    }
    in.SetInt32(&request, page_size, kPageSize);
    in.SetString(&request, page_token, "");
    std::string chunk;
    if (format == ExportFormat::kCsv) {
        SOILVOL_ASSIGN_OR_RETURN(chunk, CsvHeader(*items->message_type()));
    }
    google::protobuf::util::JsonPrintOptions json;
    json.preserve_proto_field_names = false;
    do {
        SOILVOL_RETURN_IF_ERROR(record.stop.Check("export"));
        page->Clear();
        SOILVOL_RETURN_IF_ERROR(list.call(request, page.get(), record));
        const google::protobuf::Reflection& out = *page->GetReflection();
        for (int i = 0; i < out.FieldSize(*page, items); ++i) {
            const google::protobuf::Message& item = out.GetRepeatedMessage(*page, items, i);
            if (format == ExportFormat::kCsv) {
                chunk += CsvLine(item);
            } else {
                std::string line;
                if (!google::protobuf::util::MessageToJsonString(item, &line, json).ok()) {
                    return absl::InternalError("an item does not print as JSON");
                }
                absl::StrAppend(&chunk, line, "\n");
            }
            if (chunk.size() >= kChunkBytes) {
                if (!write(std::move(chunk))) return absl::CancelledError("the client left");
                chunk.clear();
            }
        }
        in.SetString(&request, page_token, out.GetString(*page, next));
    } while (!in.GetString(request, page_token).empty());
    if (!chunk.empty() && !write(std::move(chunk))) {
        return absl::CancelledError("the client left");
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
