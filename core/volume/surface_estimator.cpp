#include "core/volume/surface_estimator.hpp"

#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/statistics.hpp"
#include "core/common/status_macros.hpp"

namespace soilvol::volume {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Sample {
    double dx, dy, z;   // offset from the cell's anchor [m], height [m]
    double w;           // kernel x ray weight x area weight
    bool tells = true;  // its ray weight is above zero: it says something of the height
};

struct PlaneFit {
    double a = 0.0, b = 0.0, c = 0.0;  // z = a + b dx + c dy
    double var_factor = 1.0;           // variance of a = sigma^2 * var_factor
    bool ok = false;
    double Residual(const Sample& s) const { return s.z - (a + b * s.dx + c * s.dy); }
};

// Weighted least squares with per-sample robust factors `rho` (empty: all 1): a plane when the
// samples spread over the window in both directions, else a level.
PlaneFit FitPlane(const std::vector<Sample>& samples, const std::vector<double>& rho,
                  double window_m, double max_slope) {
    // The symmetric sums of A' W A, A' W^2 A (for the variance) and A' W z, rows (1, dx, dy).
    double w1 = 0.0, wx = 0.0, wy = 0.0, wxx = 0.0, wxy = 0.0, wyy = 0.0;
    double v1 = 0.0, vx = 0.0, vy = 0.0, vxx = 0.0, vxy = 0.0, vyy = 0.0;
    double wz = 0.0, wxz = 0.0, wyz = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const Sample& s = samples[i];
        const double w = s.w * (rho.empty() ? 1.0 : rho[i]);
        if (w <= 0.0) continue;
        const double x = s.dx, y = s.dy, w2 = w * w;
        w1 += w;
        wx += w * x;
        wy += w * y;
        wxx += w * x * x;
        wxy += w * x * y;
        wyy += w * y * y;
        v1 += w2;
        vx += w2 * x;
        vy += w2 * y;
        vxx += w2 * x * x;
        vxy += w2 * x * y;
        vyy += w2 * y * y;
        wz += w * s.z;
        wxz += w * x * s.z;
        wyz += w * y * s.z;
        ++n;
    }
    Eigen::Matrix3d ata, aw2a;
    ata << w1, wx, wy, wx, wxx, wxy, wy, wxy, wyy;
    aw2a << v1, vx, vy, vx, vxx, vxy, vy, vxy, vyy;
    const Eigen::Vector3d atz(wz, wxz, wyz);
    PlaneFit fit;
    const double sw = ata(0, 0);
    if (n < 1 || sw <= 0.0) return fit;
    fit.ok = true;
    fit.a = atz(0) / sw;
    fit.var_factor = aw2a(0, 0) / (sw * sw);
    if (n < 6) return fit;
    const Eigen::Vector2d mean = ata.block<2, 1>(1, 0) / sw;
    const Eigen::Matrix2d cov = ata.block<2, 2>(1, 1) / sw - mean * mean.transpose();
    if (Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov).eigenvalues()(0) <
        0.01 * window_m * window_m) {
        return fit;
    }
    const Eigen::Matrix3d inv = ata.inverse();
    const Eigen::Vector3d x = inv * atz;
    if (std::hypot(x(1), x(2)) > max_slope) return fit;
    fit.a = x(0);
    fit.b = x(1);
    fit.c = x(2);
    fit.var_factor = (inv * aw2a * inv)(0, 0);
    return fit;
}

// Weighted median of the sample heights: the robust start of the fit.
double WeightedMedianZ(const std::vector<Sample>& samples) {
    std::vector<std::pair<double, double>> zw;
    double total = 0.0;
    for (const Sample& s : samples) {
        if (s.w <= 0.0) continue;
        zw.emplace_back(s.z, s.w);
        total += s.w;
    }
    if (zw.empty()) return kNaN;
    std::sort(zw.begin(), zw.end());
    double acc = 0.0;
    for (const auto& [z, w] : zw) {
        acc += w;
        if (acc >= 0.5 * total) return z;
    }
    return zw.back().first;
}

// Tukey biweight IRLS from a level at the weighted median; the residual scale is the window's
// own weighted spread, so steep walls (large height noise) and floors are judged alike.
PlaneFit RobustFit(const std::vector<Sample>& samples, double sigma, double window_m,
                   const SurfaceConfig& config, double* scale) {
    PlaneFit fit;
    fit.a = WeightedMedianZ(samples);
    fit.ok = !std::isnan(fit.a);
    std::vector<double> rho(samples.size(), 1.0);
    double s_scale = sigma;
    for (int it = 0; it < config.robust_iterations && fit.ok; ++it) {
        std::vector<double> abs_res;
        abs_res.reserve(samples.size());
        for (const Sample& s : samples) abs_res.push_back(std::abs(fit.Residual(s)));
        s_scale = std::max(sigma, 1.4826 * Median(abs_res));
        const double limit = config.tukey_sigmas * s_scale;
        for (std::size_t i = 0; i < samples.size(); ++i) {
            const double u = abs_res[i] / limit;
            rho[i] = u < 1.0 ? (1.0 - u * u) * (1.0 - u * u) : 0.0;
        }
        const PlaneFit next = FitPlane(samples, rho, window_m, config.max_slope);
        if (!next.ok) break;
        fit = next;
    }
    *scale = s_scale;
    return fit;
}

// Fine bins of a third of a cell: the area [m^2] each point stands for (its bin's area shared
// among the bin's points).
constexpr int kBinsPerCell = 3;
struct FineBins {
    std::vector<double> area;       // per point
    std::vector<uint8_t> occupied;  // per fine bin: holds a return that tells a height
};

FineBins MakeFineBins(const Grid& grid, const Cloud& points, const std::vector<float>& weights) {
    const int cols = grid.cols * kBinsPerCell, rows = grid.rows * kBinsPerCell;
    const double bin_m = grid.cell_m / kBinsPerCell;
    std::vector<int> bin(points.size(), -1);
    std::vector<int> count(static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows), 0);
    FineBins out;
    out.occupied.assign(count.size(), 0);
    for (std::size_t i = 0; i < points.size(); ++i) {
        const double fx = (static_cast<double>(points[i].x()) - grid.origin.x()) / bin_m;
        const double fy = (static_cast<double>(points[i].y()) - grid.origin.y()) / bin_m;
        if (!(fx >= 0.0 && fy >= 0.0 && fx < cols && fy < rows)) continue;
        bin[i] = static_cast<int>(fy) * cols + static_cast<int>(fx);
        ++count[static_cast<std::size_t>(bin[i])];
        if (weights.empty() || weights[i] > 0.01f)
            out.occupied[static_cast<std::size_t>(bin[i])] = 1;
    }
    out.area.assign(points.size(), 0.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (bin[i] >= 0) out.area[i] = bin_m * bin_m / count[static_cast<std::size_t>(bin[i])];
    }
    return out;
}

// Share of cell k's area inside the opening that occupied fine bins cover.
double OccupiedShare(const Grid& grid, const FineBins& bins, int cell) {
    const int cols = grid.cols * kBinsPerCell;
    const int c0 = (cell % grid.cols) * kBinsPerCell, r0 = (cell / grid.cols) * kBinsPerCell;
    int occupied = 0;
    for (int r = r0; r < r0 + kBinsPerCell; ++r) {
        for (int c = c0; c < c0 + kBinsPerCell; ++c) {
            occupied += bins.occupied[static_cast<std::size_t>(r * cols + c)];
        }
    }
    const double bin_m = grid.cell_m / kBinsPerCell;
    const double inside = grid.weight[static_cast<std::size_t>(cell)];
    return inside > 0.0 ? std::min(1.0, occupied * bin_m * bin_m / inside) : 0.0;
}

// Area [m^2] of the opening covered by the window around `cell`.
double WindowArea(const Grid& grid, int cell, int half) {
    const int col = cell % grid.cols, row = cell / grid.cols;
    double area = 0.0;
    for (int r = std::max(0, row - half); r <= std::min(grid.rows - 1, row + half); ++r) {
        for (int c = std::max(0, col - half); c <= std::min(grid.cols - 1, col + half); ++c) {
            area += grid.weight[static_cast<std::size_t>(r * grid.cols + c)];
        }
    }
    return area;
}

struct WeightedPoints {
    const Cloud& points;
    std::vector<double> w;          // ray weight x area weight
    const std::vector<float>& ray;  // ray weights; empty: all 1
};

// The samples of the window of (2 half + 1)^2 cells around `cell`, weighted by a Gaussian in
// their distance to the cell's anchor (sigma: half a cell, or a quarter of a wider window).
std::vector<Sample> GatherWindow(const Grid& grid, const CellBins& bins, const WeightedPoints& wp,
                                 int cell, int half) {
    std::vector<Sample> samples;
    const Eigen::Vector2d centre = grid.anchor[static_cast<std::size_t>(cell)];
    const double h = grid.cell_m * std::max(0.5, 0.25 * (2 * half + 1));
    const double inv_two_h2 = 1.0 / (2.0 * h * h);
    const int col = cell % grid.cols, row = cell / grid.cols;
    for (int r = std::max(0, row - half); r <= std::min(grid.rows - 1, row + half); ++r) {
        for (int c = std::max(0, col - half); c <= std::min(grid.cols - 1, col + half); ++c) {
            const auto k = static_cast<std::size_t>(r * grid.cols + c);
            for (int i = bins.start[k]; i < bins.start[k + 1]; ++i) {
                const auto j = static_cast<std::size_t>(bins.index[static_cast<std::size_t>(i)]);
                const Eigen::Vector3f& p = wp.points[j];
                if (!std::isfinite(p.z())) continue;  // says nothing; would break the sort
                const double dx = static_cast<double>(p.x()) - centre.x();
                const double dy = static_cast<double>(p.y()) - centre.y();
                samples.push_back({dx, dy, static_cast<double>(p.z()),
                                   wp.w[j] * std::exp(-(dx * dx + dy * dy) * inv_two_h2),
                                   wp.ray.empty() || wp.ray[j] > 0.01f});
            }
        }
    }
    return samples;
}

// Robust noise sigma along z: median over windows of the MAD of least-squares plane residuals.
double EstimateNoise(const Grid& grid, const CellBins& bins, const WeightedPoints& wp, int half,
                     double window_m, const SurfaceConfig& config, const StopToken& stop) {
    std::vector<double> sigmas;
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        if (grid.weight[static_cast<std::size_t>(cell)] <= 0.0) continue;
        if (stop.StopRequested()) break;
        const std::vector<Sample> samples = GatherWindow(grid, bins, wp, cell, half);
        if (samples.size() < 8) continue;
        const PlaneFit fit = FitPlane(samples, {}, window_m, config.max_slope);
        std::vector<double> abs_res;
        abs_res.reserve(samples.size());
        for (const Sample& s : samples) abs_res.push_back(std::abs(fit.Residual(s)));
        sigmas.push_back(1.4826 * Median(std::move(abs_res)));
    }
    if (sigmas.empty()) return config.default_noise_m;
    return std::max(config.min_noise_m, Median(std::move(sigmas)));
}

// How far the cell's own returns stray from its plane beyond the noise `sigma`: a return's
// squared residual times its ray weight is, for noise alone, the noise variance; the median
// over the returns that tell a height (divided by the median of a chi-square with one degree,
// 0.455) less sigma^2 is what the plane leaves out - the kink of a floor meeting a wall, a
// wall curving up to the rim.
double Misfit(const Grid& grid, const CellBins& bins, const WeightedPoints& wp, int cell,
              const PlaneFit& fit, double sigma) {
    const auto k = static_cast<std::size_t>(cell);
    const Eigen::Vector2d anchor = grid.anchor[k];
    std::vector<double> scaled;
    for (int i = bins.start[k]; i < bins.start[k + 1]; ++i) {
        const auto j = static_cast<std::size_t>(bins.index[static_cast<std::size_t>(i)]);
        const double ray = wp.ray.empty() ? 1.0 : static_cast<double>(wp.ray[j]);
        const Eigen::Vector3f& p = wp.points[j];
        if (ray <= 0.01 || !std::isfinite(p.z())) continue;
        const double e = static_cast<double>(p.z()) -
                         (fit.a + fit.b * (static_cast<double>(p.x()) - anchor.x()) +
                          fit.c * (static_cast<double>(p.y()) - anchor.y()));
        scaled.push_back(ray * e * e);
    }
    if (scaled.size() < 3) return 0.0;
    constexpr double kMedianChiSquare1 = 0.4549;
    return std::sqrt(std::max(0.0, Median(std::move(scaled)) / kMedianChiSquare1 - sigma * sigma));
}

// Points per m^2 over the opening.
double Density(const Grid& grid, const CellBins& bins) {
    double area = 0.0;
    long count = 0;
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        const auto k = static_cast<std::size_t>(cell);
        if (grid.weight[k] <= 0.0) continue;
        area += grid.weight[k];
        count += bins.start[k + 1] - bins.start[k];
    }
    return area > 0.0 ? static_cast<double>(count) / area : 0.0;
}

int WindowCells(const Grid& grid, double density, const SurfaceConfig& config) {
    if (density <= 0.0) return 1;
    const double window_m = std::sqrt(config.min_window_points / density);
    int cells = std::max(1, static_cast<int>(std::ceil(window_m / grid.cell_m - 1e-9)));
    if (cells % 2 == 0) ++cells;
    return std::min(cells, std::max(1, config.max_window_cells | 1));
}

}  // namespace

bool operator==(const SurfaceConfig& a, const SurfaceConfig& b) {
    return a.min_window_points == b.min_window_points && a.max_window_cells == b.max_window_cells &&
           a.tukey_sigmas == b.tukey_sigmas && a.robust_iterations == b.robust_iterations &&
           a.min_observed_fraction == b.min_observed_fraction && a.max_slope == b.max_slope &&
           a.min_noise_m == b.min_noise_m && a.default_noise_m == b.default_noise_m &&
           a.num_threads == b.num_threads;
}

absl::StatusOr<SurfaceMap> EstimateSurface(const Grid& grid, const Cloud& points,
                                           const std::vector<float>& weights,
                                           const SurfaceConfig& config, const StopToken& stop) {
    if (!weights.empty() && weights.size() != points.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat("surface: ", weights.size(), " weights for ", points.size(), " points"));
    }
    const CellBins bins = BinPoints(grid, points);
    const FineBins fine = MakeFineBins(grid, points, weights);
    WeightedPoints wp{points, fine.area, weights};
    for (std::size_t i = 0; i < points.size(); ++i) {
        wp.w[i] *= weights.empty() ? 1.0 : static_cast<double>(weights[i]);
    }
    SurfaceMap map;
    const double density = Density(grid, bins);
    map.window_cells = WindowCells(grid, density, config);
    const int half = map.window_cells / 2;
    const double window_m = map.window_cells * grid.cell_m;
    map.noise_sigma_m = EstimateNoise(grid, bins, wp, half, window_m, config, stop);
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    map.height.assign(num_cells, kNaN);
    map.variance.assign(num_cells, kNaN);
    map.support.assign(num_cells, 0);
    map.observed.assign(num_cells, 0.0);
    map.misfit.assign(num_cells, kNaN);
    const double sigma = map.noise_sigma_m;
    const bool fine_bins_resolve =
        density > 0.0 && grid.cell_m / kBinsPerCell >= 1.0 / std::sqrt(density);
    const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 8) num_threads(threads)
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        const auto k = static_cast<std::size_t>(cell);
        if (grid.weight[k] <= 0.0 || stop.StopRequested()) continue;
        const std::vector<Sample> samples = GatherWindow(grid, bins, wp, cell, half);
        // Measured when returns that tell a height cover a fair share of the cell (its fine
        // bins), or, for cells finer than the returns' spacing, when its window holds a fair
        // share of the returns the density puts there. A cell at the edge of a shadow, or a few
        // stray returns over a hidden floor, is a hole.
        if (fine_bins_resolve) {
            map.observed[k] = OccupiedShare(grid, fine, cell);
            if (map.observed[k] < config.min_observed_fraction || samples.size() < 3) continue;
        } else {
            const double expected = density * WindowArea(grid, cell, half);
            const auto telling = static_cast<double>(std::count_if(
                samples.begin(), samples.end(), [](const Sample& s) { return s.tells; }));
            map.observed[k] = expected > 0.0 ? std::min(1.0, telling / expected) : 0.0;
            if (telling < std::max(3.0, config.min_observed_fraction * expected)) continue;
        }
        double scale = sigma;
        const PlaneFit fit = RobustFit(samples, sigma, window_m, config, &scale);
        if (!fit.ok) continue;
        map.height[k] = fit.a;
        map.variance[k] = scale * scale * fit.var_factor;
        map.misfit[k] = Misfit(grid, bins, wp, cell, fit, sigma);
        map.support[k] = bins.start[k + 1] - bins.start[k];
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check("surface fit"));
    for (std::size_t k = 0; k < num_cells; ++k) {
        if (map.support[k] > 0) ++map.measured;
    }
    if (map.measured == 0) {
        return absl::FailedPreconditionError(
            absl::StrCat("no grid cell has enough points to fit a surface (", points.size(),
                         " points over ", grid.NumCells(), " cells of ", grid.cell_m, " m)"));
    }
    FillHoles(grid, map, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("hole filling"));
    return map;
}

void FillHoles(const Grid& grid, SurfaceMap& map, const StopToken& stop) {
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    std::vector<int> holes;
    std::vector<double> measured_var;
    for (std::size_t k = 0; k < num_cells; ++k) {
        if (grid.weight[k] <= 0.0) continue;
        if (std::isnan(map.height[k])) {
            holes.push_back(static_cast<int>(k));
        } else {
            measured_var.push_back(map.variance[k]);
        }
    }
    if (holes.empty() || measured_var.empty()) return;
    // Each hole continues the plane of the measured cells around it (growing the neighbourhood
    // until it holds enough of them): a hole along a sloped wall keeps rising towards the rim,
    // where a membrane would flatten it.
    std::vector<double> filled(holes.size(), kNaN);
    for (std::size_t h = 0; h < holes.size(); ++h) {
        if (stop.StopRequested()) return;
        const int cell = holes[h];
        const int col = cell % grid.cols, row = cell / grid.cols;
        const Eigen::Vector2d centre = grid.anchor[static_cast<std::size_t>(cell)];
        // The last reach is the grid's longer side, so every hole meets the measured cells.
        const int max_reach = std::max(grid.cols, grid.rows);
        for (int reach = 2;; reach = std::min(2 * reach, max_reach)) {
            std::vector<Sample> samples;
            const double sigma = 0.5 * reach * grid.cell_m;
            for (int r = std::max(0, row - reach); r <= std::min(grid.rows - 1, row + reach); ++r) {
                for (int c = std::max(0, col - reach); c <= std::min(grid.cols - 1, col + reach);
                     ++c) {
                    const auto k = static_cast<std::size_t>(r * grid.cols + c);
                    if (grid.weight[k] <= 0.0 || std::isnan(map.height[k])) continue;
                    const Eigen::Vector2d d = grid.anchor[k] - centre;
                    // Cauchy weights: no cell, however far, weighs nothing.
                    samples.push_back({d.x(), d.y(), map.height[k],
                                       1.0 / (1.0 + d.squaredNorm() / (sigma * sigma))});
                }
            }
            if (samples.size() < 6 && reach < max_reach) continue;
            const PlaneFit fit = FitPlane(samples, {}, 2.0 * reach * grid.cell_m, 1e9);
            if (fit.ok) filled[h] = fit.a;
            break;
        }
    }
    const double hole_variance = 2.0 * Median(std::move(measured_var));
    for (std::size_t h = 0; h < holes.size(); ++h) {
        const auto k = static_cast<std::size_t>(holes[h]);
        map.height[k] = filled[h];
        map.variance[k] = hole_variance;
        map.support[k] = 0;
    }
    map.interpolated = static_cast<int>(holes.size());
}

}  // namespace soilvol::volume
