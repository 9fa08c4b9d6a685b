#include <map>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/status_macros.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

constexpr std::int64_t kMaxRangeUs = 400LL * 24 * 3600 * 1'000'000;
constexpr std::size_t kMaxPeriods = 20000;  // 400 days of hours is 9600

/// [start, end) of the request in microseconds, checked.
absl::StatusOr<std::pair<std::int64_t, std::int64_t>> RangeOf(
    const v1::GetProductionRequest& request) {
    if (!request.has_start_time()) return absl::InvalidArgumentError("start_time: required");
    if (!request.has_end_time()) return absl::InvalidArgumentError("end_time: required");
    SOILVOL_ASSIGN_OR_RETURN(const std::int64_t start,
                             TimestampMicros(request.start_time(), "start_time"));
    SOILVOL_ASSIGN_OR_RETURN(const std::int64_t end,
                             TimestampMicros(request.end_time(), "end_time"));
    if (end <= start) return absl::InvalidArgumentError("end_time: must be after start_time");
    if (end - start > kMaxRangeUs) {
        return absl::InvalidArgumentError("end_time: at most 400 days after start_time");
    }
    return std::make_pair(ProductionBucketOf(start),
                          ProductionBucketOf(end + kProductionBucketUs - 1));
}

ProductionPeriod PeriodOf(v1::ProductionPeriod period) {
    switch (period) {
        case v1::PRODUCTION_PERIOD_HOUR:
            return ProductionPeriod::kHour;
        case v1::PRODUCTION_PERIOD_SHIFT:
            return ProductionPeriod::kShift;
        case v1::PRODUCTION_PERIOD_UNSPECIFIED:
        case v1::PRODUCTION_PERIOD_DAY:
        default:
            return ProductionPeriod::kDay;
    }
}

/// The rollup dimension a grouping reads (a label groups containers).
int DimensionOf(v1::ProductionGrouping grouping) {
    switch (grouping) {
        case v1::PRODUCTION_GROUPING_CONTAINER:
        case v1::PRODUCTION_GROUPING_LABEL:
            return kByContainer;
        case v1::PRODUCTION_GROUPING_HAUL_UNIT:
            return kByHaulUnit;
        case v1::PRODUCTION_GROUPING_MATERIAL:
            return kByMaterial;
        case v1::PRODUCTION_GROUPING_UNSPECIFIED:
        default:
            return kTotal;
    }
}

/// One row per period, in order: `rows` (one per period at most) with empty periods added.
std::vector<ProductionRow> EveryPeriod(const std::vector<ProductionRow>& rows,
                                       const std::vector<Period>& periods) {
    std::vector<ProductionRow> out(periods.size());
    for (std::size_t i = 0; i < periods.size(); ++i) out[i].period = i;
    for (const ProductionRow& row : rows) out[row.period] = row;
    return out;
}

/// "loaded_ok" for LOAD_STATUS_LOADED_OK.
std::string StatusKey(int status) {
    const std::string& name = v1::LoadStatus_Name(static_cast<v1::LoadStatus>(status));
    return absl::AsciiStrToLower(name.substr(std::string("LOAD_STATUS_").size()));
}

void ToProto(const ProductionRow& row, const Period& period, v1::ProductionRow* out) {
    *out->mutable_start_time() = TimeUtil::MicrosecondsToTimestamp(period.start_us);
    *out->mutable_end_time() = TimeUtil::MicrosecondsToTimestamp(period.end_us);
    out->set_period(period.label);
    out->set_group(row.group);
    const ProductionCell& t = row.totals;
    out->set_loads(t.loads);
    out->set_passes(t.passes);
    out->set_volume_m3(t.volume_m3);
    out->set_bank_volume_m3(t.bank_volume_m3);
    out->set_mass_kg(t.mass_kg);
    out->set_mass_passes(t.mass_passes);
    out->set_mean_fill_ratio(t.passes > 0 ? t.fill_ratio_sum / t.passes : 0.0);
    for (int s = 1; s < ProductionCell::kStatuses; ++s) {
        if (t.statuses[s] > 0) (*out->mutable_status_counts())[StatusKey(s)] = t.statuses[s];
    }
}

}  // namespace

absl::StatusOr<SiteCalendar> SoilVolumeHandlers::CalendarOf(const v1::GetProductionRequest& request,
                                                            v1::Production* response) const {
    const std::string& zone_name =
        request.time_zone().empty() ? options_.site_time_zone : request.time_zone();
    SiteCalendar calendar;
    SOILVOL_ASSIGN_OR_RETURN(calendar.zone, LoadSiteZone(zone_name, "time_zone"));
    std::vector<std::string> starts(request.shift_starts().begin(), request.shift_starts().end());
    if (starts.empty()) starts = options_.shift_starts;
    SOILVOL_ASSIGN_OR_RETURN(calendar.shift_starts_min, ParseShiftStarts(starts, "shift_starts"));
    response->set_time_zone(zone_name);
    for (const int minute : calendar.shift_starts_min) {
        response->add_shift_starts(absl::StrFormat("%02d:%02d", minute / 60, minute % 60));
    }
    return calendar;
}

std::function<std::string(const ProductionCell&)> SoilVolumeHandlers::GroupOf(
    const v1::GetProductionRequest& request) const {
    switch (request.group_by()) {
        case v1::PRODUCTION_GROUPING_CONTAINER:
            return [](const ProductionCell& cell) { return cell.container_id; };
        case v1::PRODUCTION_GROUPING_HAUL_UNIT:
            return [](const ProductionCell& cell) { return cell.haul_unit_id; };
        case v1::PRODUCTION_GROUPING_MATERIAL:
            return [](const ProductionCell& cell) { return cell.material; };
        case v1::PRODUCTION_GROUPING_LABEL: {
            // Each container's label read once per call.
            auto values = std::make_shared<std::map<std::string, std::string>>();
            return [this, values, key = request.label_key()](const ProductionCell& cell) {
                auto found = values->find(cell.container_id);
                if (found == values->end()) {
                    std::string value;
                    const auto container = LoadContainer(cell.container_id, "container_id");
                    if (container.ok()) {
                        const auto& labels = (*container)->info.labels();
                        if (auto label = labels.find(key); label != labels.end()) {
                            value = label->second;
                        }
                    }
                    found = values->emplace(cell.container_id, std::move(value)).first;
                }
                return found->second;
            };
        }
        case v1::PRODUCTION_GROUPING_UNSPECIFIED:
        default:
            return [](const ProductionCell&) { return std::string(); };
    }
}

absl::Status SoilVolumeHandlers::GetProduction(const v1::GetProductionRequest& request,
                                               v1::Production* response, CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    SOILVOL_ASSIGN_OR_RETURN(const auto range, RangeOf(request));
    if (request.group_by() == v1::PRODUCTION_GROUPING_LABEL) {
        SOILVOL_RETURN_IF_ERROR(ValidateLabel(request.label_key(), "", "label_key"));
    }
    SOILVOL_ASSIGN_OR_RETURN(const SiteCalendar calendar, CalendarOf(request, response));
    SOILVOL_ASSIGN_OR_RETURN(const int size, PageSizeOf(request.page_size()));
    SOILVOL_ASSIGN_OR_RETURN(const std::optional<std::int64_t> offset,
                             ParseRecordPageToken(request.page_token()));
    SOILVOL_ASSIGN_OR_RETURN(
        const std::vector<Period> periods,
        MakePeriods(calendar, PeriodOf(request.period()), range.first, range.second, kMaxPeriods));
    if (periods.empty()) return absl::OkStatus();
    // Every period overlapping the range counts whole, from the coarsest rollup it allows.
    SOILVOL_ASSIGN_OR_RETURN(
        const std::vector<ProductionCell> cells,
        store->ProductionCells(periods.front().start_us, periods.back().end_us,
                               DimensionOf(request.group_by()), RollupGranularityFor(periods)));
    std::vector<ProductionRow> rows = SumProduction(cells, periods, GroupOf(request));
    if (request.group_by() == v1::PRODUCTION_GROUPING_UNSPECIFIED)
        rows = EveryPeriod(rows, periods);
    const std::size_t first = static_cast<std::size_t>(offset.value_or(0));
    const std::size_t last = std::min(rows.size(), first + static_cast<std::size_t>(size));
    for (std::size_t i = first; i < last; ++i) {
        ToProto(rows[i], periods[rows[i].period], response->add_rows());
    }
    if (last < rows.size()) {
        response->set_next_page_token(RecordPageToken(static_cast<std::int64_t>(last)));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
