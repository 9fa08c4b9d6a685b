#include "core/volume/heightmap_volume.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/common/statistics.hpp"
#include "core/common/status_macros.hpp"
#include "core/volume/free_space.hpp"

namespace soilvol::volume {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double LowQuantileZ(const Cloud& points, double q) {
    std::vector<float> z;
    z.reserve(points.size());
    for (const auto& p : points) z.push_back(p.z());
    return z.empty() ? 0.0 : QuantileInPlace(z, q);
}

double MaxInradius(const Polygon2d& opening) {
    const Eigen::Vector2d lo = opening.Min(), hi = opening.Max();
    double best = 0.0;
    constexpr int kSamples = 64;
    for (int i = 0; i < kSamples; ++i) {
        for (int j = 0; j < kSamples; ++j) {
            const Eigen::Vector2d p = lo + (hi - lo).cwiseProduct(Eigen::Vector2d(
                                               (i + 0.5) / kSamples, (j + 0.5) / kSamples));
            if (opening.Contains(p)) best = std::max(best, opening.DistanceToBoundary(p));
        }
    }
    return best;
}

std::size_t CountInside(const Cloud& points, const Polygon2d& opening) {
    std::size_t n = 0;
    for (const auto& p : points) {
        if (opening.Contains(p.head<2>().cast<double>())) ++n;
    }
    return n;
}

// Several clouds' points and weights as one (a cloud without weights weighs 1 a point).
WeightedCloud Merged(const std::vector<WeightedCloud>& clouds) {
    WeightedCloud all;
    bool weighted = false;
    std::size_t n = 0;
    for (const WeightedCloud& c : clouds) {
        weighted = weighted || !c.weights.empty();
        n += c.points.size();
    }
    all.points.reserve(n);
    if (weighted) all.weights.reserve(n);
    for (const WeightedCloud& c : clouds) {
        all.points.insert(all.points.end(), c.points.begin(), c.points.end());
        if (!weighted) continue;
        if (c.weights.empty()) {
            all.weights.insert(all.weights.end(), c.points.size(), 1.0F);
        } else {
            all.weights.insert(all.weights.end(), c.weights.begin(), c.weights.end());
        }
    }
    return all;
}

// Chessboard distance, in cells, from each cell to a nearest measured one, and that cell (two
// passes; -1 where no cell is measured).
struct NearestMeasured {
    std::vector<int> cells;
    std::vector<int> source;
};

NearestMeasured CellsToMeasured(const Grid& grid, const SurfaceMap& map) {
    constexpr int kFar = 1 << 28;
    NearestMeasured out{std::vector<int>(map.support.size(), kFar),
                        std::vector<int>(map.support.size(), -1)};
    for (std::size_t k = 0; k < out.cells.size(); ++k) {
        if (grid.weight[k] > 0.0 && map.support[k] > 0) {
            out.cells[k] = 0;
            out.source[k] = static_cast<int>(k);
        }
    }
    const auto relax = [&](int r, int c, int dr, int dc) {
        const int rr = r + dr, cc = c + dc;
        if (rr < 0 || cc < 0 || rr >= grid.rows || cc >= grid.cols) return;
        const auto here = static_cast<std::size_t>(r * grid.cols + c);
        const auto there = static_cast<std::size_t>(rr * grid.cols + cc);
        if (out.cells[there] + 1 < out.cells[here]) {
            out.cells[here] = out.cells[there] + 1;
            out.source[here] = out.source[there];
        }
    };
    for (int r = 0; r < grid.rows; ++r) {
        for (int c = 0; c < grid.cols; ++c) {
            relax(r, c, -1, -1), relax(r, c, -1, 0), relax(r, c, -1, 1), relax(r, c, 0, -1);
        }
    }
    for (int r = grid.rows - 1; r >= 0; --r) {
        for (int c = grid.cols - 1; c >= 0; --c) {
            relax(r, c, 1, 1), relax(r, c, 1, 0), relax(r, c, 1, -1), relax(r, c, 0, 1);
        }
    }
    return out;
}

// Returns' mean spacing over the opening [m] (over-estimated where they cover only part of it,
// which only narrows what counts as unseen to what lies beyond that spacing).
double Spacing(const Grid& grid, std::size_t points) {
    double area = 0.0;
    for (const double w : grid.weight) area += w;
    return points > 0 ? std::sqrt(area / static_cast<double>(points)) : 0.0;
}

// A cell within 1.5 spacings of a measured one lies between samples (cells finer than the
// spacing): its fill is an interpolation with the fit's own variance, not an unseen patch with
// a range of its own. Returns scattered at random leave a gap that wide with probability
// exp(-pi 1.5^2), 0.1%.
bool Unseen(const std::vector<int>& cells_to_measured, std::size_t k, double cell_m,
            double spacing_m) {
    return cells_to_measured[k] * cell_m > 1.5 * spacing_m;
}

// The empty surface under a cell too sparsely seen to fit lies between two bounds: below, the
// plane its neighbours continue, or the returns the cell holds (the outside of a wall leaning
// over it), whichever is higher; above, the lowest ray that passed over it. With no return
// under it the cell sits at its lower bound (a vertical wall hides a floor that continues);
// its 1-sigma is that of a uniform spread over the range [m].
std::vector<double> BoundUnobservedEmpty(const Grid& grid, const std::vector<double>& ceiling,
                                         const Cloud& points, SurfaceMap& empty) {
    const CellBins bins = BinPoints(grid, points);
    const std::vector<int> gap = CellsToMeasured(grid, empty).cells;
    const double spacing = Spacing(grid, points.size());
    std::vector<double> sigma(empty.height.size(), 0.0);
    for (std::size_t k = 0; k < empty.height.size(); ++k) {
        if (grid.weight[k] <= 0.0 || empty.support[k] > 0 || !std::isfinite(ceiling[k])) continue;
        std::vector<float> z;
        for (int i = bins.start[k]; i < bins.start[k + 1]; ++i) {
            z.push_back(
                points[static_cast<std::size_t>(bins.index[static_cast<std::size_t>(i)])].z());
        }
        const double hi = std::min(ceiling[k], 0.0);
        double lo = empty.height[k];
        if (z.size() >= 3) lo = std::max(lo, Median(z));
        lo = std::min(lo, hi);
        empty.height[k] = lo;
        if (Unseen(gap, k, grid.cell_m, spacing)) sigma[k] = (hi - lo) / std::sqrt(12.0);
    }
    return sigma;
}

// The soil surface under a cell the scan did not see continues its neighbours, between the
// empty surface and the lowest ray that passed over it, and under the steepest heap rising from
// the rim. Loose soil stands no steeper than that heap slope anywhere (its angle of repose is
// below it), so the cell also lies within slope x distance of a measured cell's height: a hidden
// strip along a wall cannot hold a pit or a tower its seen neighbours rule out. Returns each
// cell's 1-sigma over that range (uniform) [m]. Where no ray passed over a cell (or the scan has
// no sensor geometry) only the heap and the slope bound it.
std::vector<double> BoundUnobservedSoil(const Grid& grid, const std::vector<double>& ceiling,
                                        const SurfaceMap& empty, const Polygon2d& opening,
                                        double heap_slope, std::size_t points, SurfaceMap& soil) {
    const NearestMeasured nearest = CellsToMeasured(grid, soil);
    const double spacing = Spacing(grid, points);
    std::vector<double> sigma(soil.height.size(), 0.0);
    for (std::size_t k = 0; k < soil.height.size(); ++k) {
        if (grid.weight[k] <= 0.0 || soil.support[k] > 0) continue;
        const double floor = empty.height[k];
        const double heap = heap_slope * opening.DistanceToBoundary(grid.anchor[k]);
        const double top = std::max(floor, std::min(ceiling[k], heap));
        soil.height[k] = std::clamp(soil.height[k], floor, top);
        double lo = floor, hi = top;
        if (nearest.source[k] >= 0) {
            const auto m = static_cast<std::size_t>(nearest.source[k]);
            const double reach = heap_slope * (grid.anchor[k] - grid.anchor[m]).norm();
            // The range holds the cell's own continuation too: a measured neighbour's height
            // carries its noise, and the continuation follows more than one neighbour.
            lo = std::min(std::max(lo, soil.height[m] - reach), soil.height[k]);
            hi = std::max(std::min(hi, soil.height[m] + reach), soil.height[k]);
        }
        if (Unseen(nearest.cells, k, grid.cell_m, spacing)) sigma[k] = (hi - lo) / std::sqrt(12.0);
    }
    return sigma;
}

}  // namespace

double AutomaticCellSize(std::size_t points_in_opening, const Polygon2d& opening,
                         const HeightmapConfig& config) {
    const Eigen::Vector2d extent = opening.Max() - opening.Min();
    const double max_cell =
        std::max(config.min_cell_m, config.max_cell_fraction * extent.minCoeff());
    if (points_in_opening == 0) return max_cell;
    const double box_m2 = extent.prod();
    const double cell = std::max(std::sqrt(config.target_points_per_cell * opening.Area() /
                                           static_cast<double>(points_in_opening)),
                                 std::sqrt(box_m2 / config.max_cells));
    if (!(cell > config.min_cell_m)) return std::min(config.min_cell_m, max_cell);
    constexpr double kStepsPerOctave = 8.0;
    double steps = std::round(kStepsPerOctave * std::log2(cell / config.min_cell_m));
    // Rounding never takes the cell count past its limit.
    if (GridCells(opening, config.min_cell_m * std::exp2(steps / kStepsPerOctave)) >
        config.max_cells) {
        steps += 1.0;
    }
    return std::min(config.min_cell_m * std::exp2(steps / kStepsPerOctave), max_cell);
}

WeightedCloud SelectColumn(const Cloud& points, const std::vector<float>& weights,
                           const Eigen::Vector3d& sensor, const Polygon2d& opening,
                           double empty_min_z, const HeightmapConfig& config) {
    const Eigen::Vector2d lo = opening.Min(), hi = opening.Max();
    const double z_min = empty_min_z - config.column_margin_m;
    const double z_max = config.max_heap_slope * MaxInradius(opening) + config.column_margin_m;
    WeightedCloud column;
    column.sensor = sensor;
    column.points.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        const Eigen::Vector3f& p = points[i];
        const double x = static_cast<double>(p.x()), y = static_cast<double>(p.y());
        const double z = static_cast<double>(p.z());
        if (x >= lo.x() && x <= hi.x() && y >= lo.y() && y <= hi.y() && z >= z_min && z <= z_max) {
            column.points.push_back(p);
            if (!weights.empty()) column.weights.push_back(weights[i]);
        }
    }
    return column;
}

absl::StatusOr<EmptySurface> EstimateEmptySurface(const Grid& grid,
                                                  const std::vector<WeightedCloud>& empty,
                                                  const HeightmapConfig& config,
                                                  const StopToken& stop) {
    const WeightedCloud all = Merged(empty);
    EmptySurface out;
    SOILVOL_ASSIGN_OR_RETURN(out.map,
                             EstimateSurface(grid, all.points, all.weights, config.surface, stop));
    SOILVOL_RETURN_IF_ERROR(stop.Check("empty surface bounds"));
    out.unobserved_sigma_m =
        BoundUnobservedEmpty(grid, FreeSpaceCeiling(grid, empty), all.points, out.map);
    for (std::size_t k = 0; k < out.map.height.size(); ++k) {
        if (grid.weight[k] <= 0.0) continue;
        out.area_m2 += grid.weight[k];
        if (out.map.support[k] > 0) out.observed_area_m2 += grid.weight[k];
    }
    return out;
}

double EmptyMinZ(const std::vector<WeightedCloud>& empty_inside) {
    double min_z = 0.0;
    for (const WeightedCloud& e : empty_inside) {
        min_z = std::min(min_z, LowQuantileZ(e.points, 0.005));
    }
    return min_z;
}

absl::StatusOr<VolumeResult> HeightmapVolume(const std::vector<WeightedCloud>& empty_inside,
                                             const std::vector<WeightedCloud>& scan,
                                             const Polygon2d& opening,
                                             const HeightmapConfig& config, const StopToken& stop) {
    const EmptySide empty{
        EmptyMinZ(empty_inside),
        [&](const Grid& grid) -> absl::StatusOr<std::shared_ptr<const EmptySurface>> {
            SOILVOL_ASSIGN_OR_RETURN(EmptySurface surface,
                                     EstimateEmptySurface(grid, empty_inside, config, stop));
            return std::make_shared<const EmptySurface>(std::move(surface));
        }};
    return HeightmapVolume(empty, scan, opening, config, stop);
}

absl::StatusOr<VolumeResult> HeightmapVolume(const EmptySide& empty_side,
                                             const std::vector<WeightedCloud>& scan,
                                             const Polygon2d& opening,
                                             const HeightmapConfig& config, const StopToken& stop) {
    std::vector<WeightedCloud> columns;
    columns.reserve(scan.size());
    for (const WeightedCloud& s : scan) {
        columns.push_back(
            SelectColumn(s.points, s.weights, s.sensor, opening, empty_side.min_z, config));
    }
    // One sensor's column is read in place; several are fitted as one.
    const WeightedCloud merged = columns.size() == 1 ? WeightedCloud{} : Merged(columns);
    const WeightedCloud& column = columns.size() == 1 ? columns.front() : merged;
    SOILVOL_RETURN_IF_ERROR(stop.Check("grid"));
    const double cell_m =
        config.cell_m > 0.0
            ? config.cell_m
            : AutomaticCellSize(CountInside(column.points, opening), opening, config);
    if (!(GridCells(opening, cell_m) <= config.max_cells)) {
        return absl::InvalidArgumentError(
            absl::StrCat("grid_cell_m: ", cell_m, " m cells give ", GridCells(opening, cell_m),
                         " cells over the opening; at most ", config.max_cells, " are allowed"));
    }
    VolumeResult result;
    result.grid = MakeGrid(opening, cell_m);
    const Grid& grid = result.grid;
    SOILVOL_ASSIGN_OR_RETURN(const std::shared_ptr<const EmptySurface> empty_entry,
                             empty_side.surface(grid));
    const EmptySurface& empty_surface = *empty_entry;
    const SurfaceMap& empty = empty_surface.map;
    const std::vector<double>& unobserved_sigma = empty_surface.unobserved_sigma_m;
    SOILVOL_RETURN_IF_ERROR(stop.Check("soil surface fit"));
    SOILVOL_ASSIGN_OR_RETURN(SurfaceMap soil, EstimateSurface(grid, column.points, column.weights,
                                                              config.surface, stop));
    SOILVOL_RETURN_IF_ERROR(stop.Check("soil surface bounds"));
    const std::vector<double> unseen_soil_sigma =
        BoundUnobservedSoil(grid, FreeSpaceCeiling(grid, columns), empty, opening,
                            config.max_heap_slope, column.points.size(), soil);
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    result.soil_height_m.assign(num_cells, kNaN);
    result.scan_surface_m.assign(num_cells, kNaN);
    result.state.assign(num_cells, CellState::kOutside);
    // Signed sum: a cell's noise below the empty surface cancels noise above it elsewhere.
    const double ks = static_cast<double>(soil.window_cells * soil.window_cells);
    const double ke = static_cast<double>(empty.window_cells * empty.window_cells);
    double variance = 0.0;
    double unobserved = 0.0;  // a hidden wall is one error over all its cells: summed linearly
    for (std::size_t k = 0; k < num_cells; ++k) {
        const double w = grid.weight[k];
        if (w <= 0.0) continue;
        const double h = soil.height[k] - empty.height[k];
        const double var = ks * soil.variance[k] + ke * empty.variance[k];
        result.soil_height_m[k] = h;
        result.scan_surface_m[k] = soil.height[k];
        result.raw_volume_m3 += w * h;
        variance += w * w * var;
        // Where neither surface was seen the contents lie between 0 and the scan's ceiling
        // above the empty surface's lower bound: one range, not two.
        unobserved += w * std::max(unobserved_sigma[k], unseen_soil_sigma[k]);
        // A measured empty cell whose plane does not follow its surface: one wall, one error.
        if (k < empty.misfit.size() && std::isfinite(empty.misfit[k]))
            unobserved += w * empty.misfit[k];
        ++result.cells.total;
        if (soil.support[k] > 0) {
            result.state[k] = CellState::kMeasured;
            ++result.cells.measured;
        } else {
            result.state[k] = CellState::kInterpolated;
            ++result.cells.interpolated;
        }
        const double cell_sigma = std::sqrt(soil.variance[k] + empty.variance[k]);
        if (h > 2.0 * cell_sigma) ++result.cells.with_soil;
        if (soil.support[k] > 0 && empty.support[k] > 0) {
            ++result.cells.both_measured;
            if (h < -3.0 * std::max(cell_sigma, soil.noise_sigma_m)) ++result.cells.below_empty;
        }
    }
    double area = 0.0, scan_seen = 0.0;
    for (std::size_t k = 0; k < num_cells; ++k) {
        area += grid.weight[k];
        if (soil.support[k] > 0) scan_seen += grid.weight[k];
    }
    result.scan_observed_share = area > 0.0 ? scan_seen / area : 0.0;
    result.empty_observed_share =
        empty_surface.area_m2 > 0.0 ? empty_surface.observed_area_m2 / empty_surface.area_m2 : 0.0;
    result.volume_m3 = std::max(0.0, result.raw_volume_m3);
    result.uncertainty_m3 = std::hypot(std::sqrt(variance), unobserved);
    result.unobserved_uncertainty_m3 = unobserved;
    result.scan_noise_sigma_m = soil.noise_sigma_m;
    result.model_noise_sigma_m = empty.noise_sigma_m;
    result.window_cells = soil.window_cells;
    return result;
}

}  // namespace soilvol::volume
