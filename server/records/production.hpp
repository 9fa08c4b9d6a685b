#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace soilvol::server {

/// Production totals are kept per 15 minutes of UTC (every IANA zone's offset is a multiple of
/// it, so every hour, shift and day of any zone is a union of buckets).
inline constexpr std::int64_t kProductionBucketUs = 15LL * 60 * 1'000'000;

/// The bucket (its start, us since the epoch) of a time.
std::int64_t ProductionBucketOf(std::int64_t time_us);

/// What one estimate adds to production (its record's columns); body scans of loads add none
/// (their soil was counted in the passes).
struct Measures {
    double volume_m3 = 0.0;  ///< loose
    double bank_volume_m3 = 0.0;
    std::optional<double> mass_kg;
    double fill_ratio = 0.0;
    int load_status = 0;  ///< soilvol.v1.LoadStatus: 0..6
    std::string material;
};

/// One bucket of one (container, haul unit, material): the store's rollup, kept in the same
/// transaction as the records.
struct ProductionCell {
    static constexpr int kStatuses = 7;  ///< soilvol.v1.LoadStatus values 0..6
    std::int64_t bucket_us = 0;
    std::string container_id, haul_unit_id, material;
    std::int64_t passes = 0;  ///< estimates (a load's pass or no load's)
    std::int64_t loads = 0;   ///< loads whose first pass is in this cell
    double volume_m3 = 0.0, bank_volume_m3 = 0.0, mass_kg = 0.0;
    std::int64_t mass_passes = 0;  ///< estimates with a mass
    double fill_ratio_sum = 0.0;
    std::array<std::int64_t, kStatuses> statuses{};
};

/// The cell one kept record adds: `measures` at `time_us` of `container_id`, in the load of
/// `haul_unit_id` ("" for none), `first_pass` when it is its load's first.
ProductionCell CellOf(const Measures& measures, const std::string& container_id,
                      const std::string& haul_unit_id, std::int64_t time_us, bool first_pass);

/// The store keeps production twice. The fine table has one row per 15-minute bucket,
/// container, haul unit and material (the truth: purging a container's records removes its
/// rows there). The rollup, derived from it in the same transactions, has one row per
/// granularity (15 minutes, an hour), dimension and bucket, keyed by the dimension's value
/// alone: a query reads one dimension at the coarsest granularity its periods allow, a few
/// rows per period instead of the cross product of containers, trucks and materials.
enum ProductionDimension { kTotal = 0, kByContainer = 1, kByHaulUnit = 2, kByMaterial = 3 };
inline constexpr int kProductionDimensions = 4;
inline constexpr std::int64_t kRollupGranularitiesUs[] = {kProductionBucketUs,
                                                          4 * kProductionBucketUs};

/// Where one fine cell adds in the rollup: its bucket at every granularity, in every dimension.
struct RollupKey {
    std::int64_t granularity_us = 0;
    int dimension = kTotal;
    std::int64_t bucket_us = 0;
    std::string key;
};
std::vector<RollupKey> RollupKeysOf(const ProductionCell& fine);

/// A rollup row's key into the field of its dimension.
void SetCellKey(int dimension, std::string key, ProductionCell& cell);

/// `from`'s values added to `into`'s (its keys stay).
void AddCellValues(const ProductionCell& from, ProductionCell& into);

/// What a batch of kept records adds: its fine cells summed by their keys, and the rollup's
/// rows they add to summed by theirs (one row each: a statement may touch a row once).
struct ProductionBatch {
    std::vector<ProductionCell> fine;
    std::vector<std::pair<RollupKey, ProductionCell>> rollup;
};
ProductionBatch SumBatch(const std::vector<ProductionCell>& cells);

/// The SQL of both stores: `p` the parameter mark ('?' SQLite, '$' PostgreSQL).
/// Adds `rows` cells to the fine table (18 parameters a row: bucket, container, haul unit,
/// material, passes, loads, volume, bank volume, mass, mass passes, fill sum, statuses 0-6).
std::string ProductionUpsertSql(const std::string& table, char p, int rows = 1);
/// Adds `rows` rows to the rollup (18 parameters a row: granularity, dimension, bucket, key,
/// then the values).
std::string RollupUpsertSql(const std::string& table, char p, int rows = 1);
/// The rollup's rows of one granularity and dimension with buckets in [param 3, param 4):
/// bucket_us, key, the values.
std::string RollupSelectSql(const std::string& table, char p);
/// The statements that make the rollup anew from the fine table (after a purge, or for a
/// database made before the rollup).
std::vector<std::string> RollupRebuildSql(const std::string& fine, const std::string& rollup);

/// Periods of a site's day in its IANA zone.
struct SiteCalendar {
    absl::TimeZone zone;
    /// Minutes after local midnight each shift starts, ascending, each a multiple of 15; a
    /// shift runs to the next one's start (the last to the first's, the next day).
    std::vector<int> shift_starts_min;
};

/// An IANA zone by its name ("Europe/Berlin", "UTC"): 1-64 characters, segments of
/// [A-Za-z0-9_+-] between single slashes (no path of its own: a name never reaches beyond the
/// zone database), found in the system's tzdata. InvalidArgument naming `field` otherwise.
absl::StatusOr<absl::TimeZone> LoadSiteZone(const std::string& name, const char* field);

/// "06:00,18:00" (local times, each a multiple of 15 minutes, 1 to 12 of them) into minutes;
/// InvalidArgument naming `field` otherwise. Duplicates are refused; the order need not be.
absl::StatusOr<std::vector<int>> ParseShiftStarts(const std::vector<std::string>& starts,
                                                  const char* field);

enum class ProductionPeriod { kHour, kShift, kDay };

/// One period: [start, end) in UTC microseconds, its label in the site's zone
/// ("2026-12-07T06:00+01:00" hours, "2026-12-07 shift 1 (06:00)", "2026-12-07" days).
struct Period {
    std::int64_t start_us = 0, end_us = 0;
    std::string label;
};

/// The periods that overlap [start_us, end_us), in order, at most `max_periods` (more:
/// InvalidArgument naming end_time). Local times a clock change skips or repeats resolve as
/// absl does (a skipped 02:30 is the instant after the change; a day is 23 or 25 hours long).
absl::StatusOr<std::vector<Period>> MakePeriods(const SiteCalendar& calendar,
                                                ProductionPeriod period, std::int64_t start_us,
                                                std::int64_t end_us, std::size_t max_periods);

/// The coarsest rollup granularity on which every period boundary falls.
std::int64_t RollupGranularityFor(const std::vector<Period>& periods);

/// Totals of one period and group.
struct ProductionRow {
    std::size_t period = 0;  ///< index into the periods
    std::string group;       ///< "" when not grouped
    ProductionCell totals;   ///< the values summed (AddCellValues); its keys unused
};

/// `cells` summed by period and by the group `group_of` names each cell (a cell no period
/// holds is left out), ordered by period then group.
std::vector<ProductionRow> SumProduction(
    const std::vector<ProductionCell>& cells, const std::vector<Period>& periods,
    const std::function<std::string(const ProductionCell&)>& group_of);

}  // namespace soilvol::server
