#include "server/records/production.hpp"

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <map>
#include <tuple>
#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_split.h"

namespace soilvol::server {
namespace {

absl::Time TimeOfMicros(std::int64_t us) { return absl::FromUnixMicros(us); }
std::int64_t MicrosOf(absl::Time t) { return absl::ToUnixMicros(t); }

/// The instant of local civil time `civil` in `zone` (a skipped time: the instant after the
/// change; a repeated one: its first occurrence).
absl::Time Instant(const absl::CivilMinute& civil, const absl::TimeZone& zone) {
    const absl::TimeZone::TimeInfo info = zone.At(civil);
    return info.kind == absl::TimeZone::TimeInfo::SKIPPED ? info.trans : info.pre;
}

/// Every boundary of `period` from the local day before `start` to the one after `end`.
std::vector<std::pair<absl::Time, std::string>> Boundaries(const SiteCalendar& calendar,
                                                           ProductionPeriod period,
                                                           absl::Time start, absl::Time end) {
    const absl::CivilDay first = absl::ToCivilDay(start, calendar.zone) - 1;
    const absl::CivilDay last = absl::ToCivilDay(end, calendar.zone) + 1;
    std::vector<std::pair<absl::Time, std::string>> out;
    for (absl::CivilDay day = first; day <= last; ++day) {
        const std::string date = absl::FormatCivilTime(day);
        switch (period) {
            case ProductionPeriod::kDay:
                out.push_back({Instant(absl::CivilMinute(day), calendar.zone), date});
                break;
            case ProductionPeriod::kShift:
                for (std::size_t i = 0; i < calendar.shift_starts_min.size(); ++i) {
                    const int minute = calendar.shift_starts_min[i];
                    out.push_back({Instant(absl::CivilMinute(day) + minute, calendar.zone),
                                   absl::StrFormat("%s shift %d (%02d:%02d)", date, i + 1,
                                                   minute / 60, minute % 60)});
                }
                break;
            case ProductionPeriod::kHour:
                break;  // below, in absolute time
        }
    }
    if (period == ProductionPeriod::kHour) {
        // Every quarter hour whose local minute is 0 starts an hour: a clock change back
        // repeats an hour (two periods, their offsets in the labels), one forward skips one.
        const absl::Time from = Instant(absl::CivilMinute(first), calendar.zone);
        const absl::Time to = Instant(absl::CivilMinute(last + 1), calendar.zone);
        for (absl::Time at = from; at <= to; at += absl::Minutes(15)) {
            if (absl::ToCivilMinute(at, calendar.zone).minute() != 0) continue;
            out.push_back({at, absl::FormatTime("%Y-%m-%dT%H:%M%Ez", at, calendar.zone)});
        }
    }
    // Shift starts a clock change skips collapse into the next instant: dropped below.
    std::stable_sort(out.begin(), out.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const auto& a, const auto& b) { return a.first == b.first; }),
              out.end());
    return out;
}

}  // namespace

std::int64_t ProductionBucketOf(std::int64_t time_us) {
    std::int64_t bucket = time_us / kProductionBucketUs;
    if (time_us % kProductionBucketUs < 0) --bucket;  // floor, also before 1970
    return bucket * kProductionBucketUs;
}

ProductionCell CellOf(const Measures& measures, const std::string& container_id,
                      const std::string& haul_unit_id, std::int64_t time_us, bool first_pass) {
    ProductionCell cell;
    cell.bucket_us = ProductionBucketOf(time_us);
    cell.container_id = container_id;
    cell.haul_unit_id = haul_unit_id;
    cell.material = measures.material;
    cell.passes = 1;
    cell.loads = first_pass ? 1 : 0;
    cell.volume_m3 = measures.volume_m3;
    cell.bank_volume_m3 = measures.bank_volume_m3;
    cell.mass_kg = measures.mass_kg.value_or(0.0);
    cell.mass_passes = measures.mass_kg ? 1 : 0;
    cell.fill_ratio_sum = measures.fill_ratio;
    cell.statuses[static_cast<std::size_t>(
        std::clamp(measures.load_status, 0, ProductionCell::kStatuses - 1))] = 1;
    return cell;
}

namespace {

/// Each dimension's key in the fine table ('' for the total).
constexpr const char* kDimensionColumns[kProductionDimensions] = {"''", "container_id",
                                                                  "haul_unit_id", "material"};
constexpr const char* kValueColumns[] = {
    "passes",      "loads",          "volume_m3", "bank_volume_m3", "mass_kg",
    "mass_passes", "fill_ratio_sum", "status_0",  "status_1",       "status_2",
    "status_3",    "status_4",       "status_5",  "status_6"};

}  // namespace

namespace {

std::string Param(char p, int n) { return absl::StrCat(std::string(1, p), n); }

/// "passes = t.passes + excluded.passes, ..." for every value column.
std::string AddedValues(const std::string& table) {
    std::string updates;
    for (const char* column : kValueColumns) {
        absl::StrAppend(&updates, updates.empty() ? "" : ", ", column, " = ", table, ".", column,
                        " + excluded.", column);
    }
    return updates;
}

std::string ValueList(const char* wrap) {
    std::string list;
    for (const char* column : kValueColumns) {
        absl::StrAppend(&list, list.empty() ? "" : ", ", wrap, column, *wrap ? ")" : "");
    }
    return list;
}

/// "(p1, ..., p18), (p19, ...)": `rows` rows of a cell's 18 parameters.
std::string ParamRows(char p, int rows) {
    constexpr int kPerRow = 4 + static_cast<int>(std::size(kValueColumns));
    std::string out;
    for (int row = 0; row < rows; ++row) {
        absl::StrAppend(&out, row == 0 ? "(" : ", (");
        for (int i = 1; i <= kPerRow; ++i) {
            absl::StrAppend(&out, i == 1 ? "" : ", ", Param(p, row * kPerRow + i));
        }
        out += ")";
    }
    return out;
}

/// Adds `rows` rows keyed by `keys` (comma-separated, the table's primary key) to `table`.
std::string UpsertSql(const std::string& table, const char* keys, char p, int rows) {
    return absl::StrCat("INSERT INTO ", table, " (", keys, ", ", ValueList(""), ") VALUES ",
                        ParamRows(p, rows), " ON CONFLICT (", keys, ") DO UPDATE SET ",
                        AddedValues(table));
}

}  // namespace

std::string ProductionUpsertSql(const std::string& table, char p, int rows) {
    return UpsertSql(table, "bucket_us, container_id, haul_unit_id, material", p, rows);
}

std::string RollupUpsertSql(const std::string& table, char p, int rows) {
    return UpsertSql(table, "granularity_us, dimension, bucket_us, key", p, rows);
}

void AddCellValues(const ProductionCell& from, ProductionCell& into) {
    into.passes += from.passes;
    into.loads += from.loads;
    into.volume_m3 += from.volume_m3;
    into.bank_volume_m3 += from.bank_volume_m3;
    into.mass_kg += from.mass_kg;
    into.mass_passes += from.mass_passes;
    into.fill_ratio_sum += from.fill_ratio_sum;
    for (int s = 0; s < ProductionCell::kStatuses; ++s) into.statuses[s] += from.statuses[s];
}

ProductionBatch SumBatch(const std::vector<ProductionCell>& cells) {
    std::map<std::tuple<std::int64_t, std::string, std::string, std::string>, ProductionCell> fine;
    std::map<std::tuple<std::int64_t, int, std::int64_t, std::string>,
             std::pair<RollupKey, ProductionCell>>
        rollup;
    for (const ProductionCell& cell : cells) {
        ProductionCell& f =
            fine[{cell.bucket_us, cell.container_id, cell.haul_unit_id, cell.material}];
        if (f.passes == 0 && f.mass_passes == 0) {
            f.bucket_us = cell.bucket_us;
            f.container_id = cell.container_id;
            f.haul_unit_id = cell.haul_unit_id;
            f.material = cell.material;
        }
        AddCellValues(cell, f);
        for (RollupKey& key : RollupKeysOf(cell)) {
            auto& [at, sum] = rollup[{key.granularity_us, key.dimension, key.bucket_us, key.key}];
            at = std::move(key);
            AddCellValues(cell, sum);
        }
    }
    ProductionBatch out;
    for (auto& [key, cell] : fine) out.fine.push_back(std::move(cell));
    for (auto& [key, entry] : rollup) out.rollup.push_back(std::move(entry));
    return out;
}

std::string RollupSelectSql(const std::string& table, char p) {
    return absl::StrCat("SELECT bucket_us, key, ", ValueList(""), " FROM ", table,
                        " WHERE granularity_us = ", Param(p, 1), " AND dimension = ", Param(p, 2),
                        " AND bucket_us >= ", Param(p, 3), " AND bucket_us < ", Param(p, 4));
}

std::vector<std::string> RollupRebuildSql(const std::string& fine, const std::string& rollup) {
    std::vector<std::string> out = {absl::StrCat("DELETE FROM ", rollup)};
    for (const std::int64_t granularity : kRollupGranularitiesUs) {
        const std::string bucket =
            absl::StrCat("(bucket_us - (bucket_us % ", granularity, "))");  // times after 1970
        for (int dimension = 0; dimension < kProductionDimensions; ++dimension) {
            const char* key = kDimensionColumns[dimension];
            out.push_back(absl::StrCat("INSERT INTO ", rollup,
                                       " (granularity_us, dimension, "
                                       "bucket_us, key, ",
                                       ValueList(""), ") SELECT ", granularity, ", ", dimension,
                                       ", ", bucket, ", ", key, ", ", ValueList("SUM("), " FROM ",
                                       fine, " GROUP BY ", bucket,
                                       dimension == kTotal ? "" : absl::StrCat(", ", key)));
        }
    }
    return out;
}

absl::StatusOr<absl::TimeZone> LoadSiteZone(const std::string& name, const char* field) {
    const auto refused = [&] {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ": not an IANA time zone name (Europe/Berlin)"));
    };
    if (name.empty() || name.size() > 64) return refused();
    for (const absl::string_view segment : absl::StrSplit(name, '/')) {
        if (segment.empty() || segment == "." || segment == "..") return refused();
        for (const char c : segment) {
            const bool allowed = absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '_' ||
                                 c == '+' || c == '-';
            if (!allowed) return refused();
        }
    }
    absl::TimeZone zone;
    if (!absl::LoadTimeZone(name, &zone)) {
        return absl::InvalidArgumentError(absl::StrCat(
            field, ": '", name, "' is not in this system's time zone database (tzdata)"));
    }
    return zone;
}

absl::StatusOr<std::vector<int>> ParseShiftStarts(const std::vector<std::string>& starts,
                                                  const char* field) {
    if (starts.empty() || starts.size() > 12) {
        return absl::InvalidArgumentError(absl::StrCat(field, ": 1 to 12 shift starts"));
    }
    std::vector<int> minutes;
    for (const std::string& text : starts) {
        int hours = -1, mins = -1;
        char extra = 0;
        const bool parsed =
            text.size() == 5 && std::sscanf(text.c_str(), "%2d:%2d%c", &hours, &mins, &extra) == 2;
        if (!parsed || hours < 0 || hours > 23 || mins < 0 || mins > 59 || mins % 15 != 0) {
            return absl::InvalidArgumentError(absl::StrCat(
                field, ": '", text, "' is not a local time HH:MM on a quarter hour (06:00)"));
        }
        minutes.push_back(hours * 60 + mins);
    }
    std::sort(minutes.begin(), minutes.end());
    if (std::adjacent_find(minutes.begin(), minutes.end()) != minutes.end()) {
        return absl::InvalidArgumentError(absl::StrCat(field, ": a shift start is repeated"));
    }
    return minutes;
}

absl::StatusOr<std::vector<Period>> MakePeriods(const SiteCalendar& calendar,
                                                ProductionPeriod period, std::int64_t start_us,
                                                std::int64_t end_us, std::size_t max_periods) {
    const auto boundaries =
        Boundaries(calendar, period, TimeOfMicros(start_us), TimeOfMicros(end_us));
    std::vector<Period> out;
    for (std::size_t i = 0; i + 1 < boundaries.size(); ++i) {
        const std::int64_t from = MicrosOf(boundaries[i].first);
        const std::int64_t to = MicrosOf(boundaries[i + 1].first);
        if (to <= start_us || from >= end_us) continue;
        if (out.size() == max_periods) {
            return absl::InvalidArgumentError(
                absl::StrCat("end_time: the range holds more than ", max_periods,
                             " periods; ask for a shorter range or a longer period"));
        }
        out.push_back({from, to, boundaries[i].second});
    }
    return out;
}

std::vector<RollupKey> RollupKeysOf(const ProductionCell& fine) {
    std::vector<RollupKey> out;
    for (const std::int64_t granularity : kRollupGranularitiesUs) {
        const std::int64_t bucket =
            fine.bucket_us - (((fine.bucket_us % granularity) + granularity) % granularity);
        out.push_back({granularity, kTotal, bucket, ""});
        out.push_back({granularity, kByContainer, bucket, fine.container_id});
        out.push_back({granularity, kByHaulUnit, bucket, fine.haul_unit_id});
        out.push_back({granularity, kByMaterial, bucket, fine.material});
    }
    return out;
}

void SetCellKey(int dimension, std::string key, ProductionCell& cell) {
    switch (dimension) {
        case kByContainer:
            cell.container_id = std::move(key);
            break;
        case kByHaulUnit:
            cell.haul_unit_id = std::move(key);
            break;
        case kByMaterial:
            cell.material = std::move(key);
            break;
        default:
            break;
    }
}

std::int64_t RollupGranularityFor(const std::vector<Period>& periods) {
    for (auto g = std::rbegin(kRollupGranularitiesUs); g != std::rend(kRollupGranularitiesUs);
         ++g) {
        const bool aligned = std::all_of(periods.begin(), periods.end(), [g](const Period& p) {
            return p.start_us % *g == 0 && p.end_us % *g == 0;
        });
        if (aligned) return *g;
    }
    return kProductionBucketUs;
}

std::vector<ProductionRow> SumProduction(
    const std::vector<ProductionCell>& cells, const std::vector<Period>& periods,
    const std::function<std::string(const ProductionCell&)>& group_of) {
    std::map<std::pair<std::size_t, std::string>, ProductionRow> rows;
    for (const ProductionCell& cell : cells) {
        // The first period that ends after the cell's start holds it (periods are contiguous
        // and every boundary falls on a bucket's).
        const auto found =
            std::upper_bound(periods.begin(), periods.end(), cell.bucket_us,
                             [](std::int64_t t, const Period& p) { return t < p.end_us; });
        if (found == periods.end() || cell.bucket_us < found->start_us) continue;
        const auto index = static_cast<std::size_t>(found - periods.begin());
        std::string group = group_of(cell);
        ProductionRow& row = rows[{index, group}];
        row.period = index;
        row.group = std::move(group);
        AddCellValues(cell, row.totals);
    }
    std::vector<ProductionRow> out;
    out.reserve(rows.size());
    for (auto& [key, row] : rows) out.push_back(std::move(row));
    return out;
}

}  // namespace soilvol::server
