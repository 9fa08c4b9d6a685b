#include "core/volume/surface_estimator.hpp"

#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace soilvol::volume {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Sample {
    double dx, dy, z;  // offset from the cell's anchor [m], height [m]
    double w;          // weight: Gaussian in the distance to the anchor
};

struct PlaneFit {
    double a = 0.0, b = 0.0, c = 0.0;  // z = a + b dx + c dy
    double var_factor = 1.0;           // variance of a = sigma^2 * var_factor
    bool ok = false;
    double Residual(const Sample& s) const { return s.z - (a + b * s.dx + c * s.dy); }
};

// Weighted least squares over the samples with |residual| <= band under `prior` (all when
// band <= 0): a level when the points are few or bunched, else a plane.
PlaneFit FitInliers(const std::vector<Sample>& samples, const PlaneFit& prior, double band,
                    double window_m, double max_slope) {
    Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();   // A' W A
    Eigen::Matrix3d aw2a = Eigen::Matrix3d::Zero();  // A' W^2 A, for the variance
    Eigen::Vector3d atz = Eigen::Vector3d::Zero();
    int n = 0;
    for (const Sample& s : samples) {
        if (band > 0.0 && std::abs(prior.Residual(s)) > band) continue;
        const Eigen::Vector3d row(1.0, s.dx, s.dy);
        ata += s.w * row * row.transpose();
        aw2a += s.w * s.w * row * row.transpose();
        atz += s.w * row * s.z;
        ++n;
    }
    PlaneFit fit;
    const double sw = ata(0, 0);
    if (n < 1 || sw <= 0.0) return fit;
    fit.ok = true;
    fit.a = atz(0) / sw;
    fit.var_factor = aw2a(0, 0) / (sw * sw);
    if (n < 6) return fit;
    // Slope only when the points spread over the window in both directions.
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

int CountInliers(const std::vector<Sample>& samples, const PlaneFit& fit, double band) {
    int count = 0;
    for (const Sample& s : samples) {
        if (std::abs(fit.Residual(s)) <= band) ++count;
    }
    return count;
}

struct Hypothesis {
    PlaneFit fit;
    double support = 0.0;  // summed weights of its inliers
    double mean_z = 0.0;   // weighted mean height of its inliers
};

Hypothesis Score(const std::vector<Sample>& samples, const PlaneFit& fit, double band, int stride) {
    Hypothesis h{fit, 0.0, 0.0};
    for (std::size_t i = 0; i < samples.size(); i += static_cast<std::size_t>(stride)) {
        const Sample& s = samples[i];
        if (std::abs(fit.Residual(s)) > band) continue;
        h.support += s.w;
        h.mean_z += s.w * s.z;
    }
    if (h.support > 0.0) h.mean_z /= h.support;
    return h;
}

// RANSAC over height-form planes and level hypotheses, support weighted towards the anchor. Seen
// from above, the contents' surface is the lowest well-supported layer: walls leaking into a
// cell through noise lie above it and nothing lies below it, so among hypotheses with at least
// `support_ratio` of the best support the one whose inliers lie lowest wins.
PlaneFit Ransac(const std::vector<Sample>& samples, double sigma, const SurfaceConfig& config,
                std::mt19937& rng) {
    const int n = static_cast<int>(samples.size());
    const int stride = std::max(1, n / 256);
    const double band = 2.0 * sigma;
    std::vector<Hypothesis> hypotheses;
    std::uniform_int_distribution<int> pick(0, n - 1);
    for (int it = 0; it < config.ransac_iterations; ++it) {
        PlaneFit level;
        level.a = samples[static_cast<std::size_t>(pick(rng))].z;
        level.ok = true;
        hypotheses.push_back(Score(samples, level, band, stride));
        if (n < 6) continue;
        const Sample& p = samples[static_cast<std::size_t>(pick(rng))];
        const Sample& q = samples[static_cast<std::size_t>(pick(rng))];
        const Sample& r = samples[static_cast<std::size_t>(pick(rng))];
        Eigen::Matrix3d m;
        m << 1.0, p.dx, p.dy, 1.0, q.dx, q.dy, 1.0, r.dx, r.dy;
        if (std::abs(m.determinant()) < 1e-12) continue;
        const Eigen::Vector3d x = m.inverse() * Eigen::Vector3d(p.z, q.z, r.z);
        if (std::hypot(x(1), x(2)) > config.max_slope) continue;
        PlaneFit plane;
        plane.a = x(0);
        plane.b = x(1);
        plane.c = x(2);
        plane.ok = true;
        hypotheses.push_back(Score(samples, plane, band, stride));
    }
    double best_support = 0.0;
    for (const Hypothesis& h : hypotheses) best_support = std::max(best_support, h.support);
    const Hypothesis* chosen = nullptr;
    for (const Hypothesis& h : hypotheses) {
        if (h.support < config.support_ratio * best_support) continue;
        if (chosen == nullptr || h.mean_z < chosen->mean_z) chosen = &h;
    }
    return chosen != nullptr ? chosen->fit : PlaneFit{};
}

// The points of the window of (2 half + 1)^2 cells around `cell`, weighted by a Gaussian in their
// distance to the cell's anchor (sigma: half a cell, or a quarter of a wider window): the cell's
// own points dominate while the neighbours' steady the fit.
std::vector<Sample> GatherWindow(const Grid& grid, const CellBins& bins, const Cloud& points,
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
                const Eigen::Vector3f& p =
                    points[static_cast<std::size_t>(bins.index[static_cast<std::size_t>(i)])];
                const double dx = static_cast<double>(p.x()) - centre.x();
                const double dy = static_cast<double>(p.y()) - centre.y();
                samples.push_back({dx, dy, static_cast<double>(p.z()),
                                   std::exp(-(dx * dx + dy * dy) * inv_two_h2)});
            }
        }
    }
    return samples;
}

double Median(std::vector<double> values) {
    if (values.empty()) return kNaN;
    const auto mid = values.begin() + static_cast<long>(values.size() / 2);
    std::nth_element(values.begin(), mid, values.end());
    return *mid;
}

// Robust noise sigma along z: median over windows of the MAD of least-squares plane residuals.
double EstimateNoise(const Grid& grid, const CellBins& bins, const Cloud& points, int half,
                     double window_m, const SurfaceConfig& config) {
    std::vector<double> sigmas;
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        if (grid.weight[static_cast<std::size_t>(cell)] <= 0.0) continue;
        const std::vector<Sample> samples = GatherWindow(grid, bins, points, cell, half);
        if (samples.size() < 8) continue;
        const PlaneFit fit = FitInliers(samples, PlaneFit{}, 0.0, window_m, config.max_slope);
        std::vector<double> abs_res;
        abs_res.reserve(samples.size());
        for (const Sample& s : samples) abs_res.push_back(std::abs(fit.Residual(s)));
        sigmas.push_back(1.4826 * Median(std::move(abs_res)));
    }
    if (sigmas.empty()) return config.default_noise_m;
    return std::max(config.min_noise_m, Median(std::move(sigmas)));
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

}  // namespace

absl::StatusOr<SurfaceMap> EstimateSurface(const Grid& grid, const Cloud& points,
                                           const SurfaceConfig& config) {
    const CellBins bins = BinPoints(grid, points);
    SurfaceMap map;
    const double density = Density(grid, bins);
    map.window_cells = WindowCells(grid, density, config);
    const int half = map.window_cells / 2;
    const double window_m = map.window_cells * grid.cell_m;
    map.noise_sigma_m = EstimateNoise(grid, bins, points, half, window_m, config);
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    map.height.assign(num_cells, kNaN);
    map.variance.assign(num_cells, kNaN);
    map.support.assign(num_cells, 0);
    const double sigma = map.noise_sigma_m;
    const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
#pragma omp parallel for schedule(dynamic, 8) num_threads(threads)
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        const auto k = static_cast<std::size_t>(cell);
        if (grid.weight[k] <= 0.0) continue;
        const std::vector<Sample> samples = GatherWindow(grid, bins, points, cell, half);
        if (samples.size() < 3) continue;
        std::mt19937 rng(static_cast<unsigned>(cell) * 2654435761u + 17u);
        PlaneFit fit = Ransac(samples, sigma, config, rng);
        // Trimmed least squares around the consensus, three rounds.
        for (int round = 0; round < 3 && fit.ok; ++round) {
            const PlaneFit next =
                FitInliers(samples, fit, config.inlier_sigmas * sigma, window_m, config.max_slope);
            if (!next.ok) break;
            fit = next;
        }
        // A consensus far below what the window should see (rim points leaking over an
        // occluded floor) is a hole, not surface.
        const int inliers = CountInliers(samples, fit, config.inlier_sigmas * sigma);
        const double expected = density * WindowArea(grid, cell, half);
        if (!fit.ok || inliers < std::max(3.0, config.min_support_fraction * expected)) continue;
        map.height[k] = fit.a;
        map.variance[k] = sigma * sigma * fit.var_factor;
        map.support[k] = inliers;
    }
    for (std::size_t k = 0; k < num_cells; ++k) {
        if (map.support[k] > 0) ++map.measured;
    }
    if (map.measured == 0) {
        return absl::FailedPreconditionError(
            absl::StrCat("no grid cell has enough points to fit a surface (", points.size(),
                         " points over ", grid.NumCells(), " cells of ", grid.cell_m, " m)"));
    }
    FillHoles(grid, map);
    return map;
}

void FillHoles(const Grid& grid, SurfaceMap& map) {
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    std::vector<int> holes;
    std::vector<double> measured_var;
    double mean = 0.0;
    for (std::size_t k = 0; k < num_cells; ++k) {
        if (grid.weight[k] <= 0.0) continue;
        if (std::isnan(map.height[k])) {
            holes.push_back(static_cast<int>(k));
        } else {
            measured_var.push_back(map.variance[k]);
            mean += map.height[k];
        }
    }
    if (holes.empty() || measured_var.empty()) return;
    mean /= static_cast<double>(measured_var.size());
    for (const int h : holes) map.height[static_cast<std::size_t>(h)] = mean;
    // Gauss-Seidel on the Laplace equation with the measured cells as boundary values.
    for (int sweep = 0; sweep < 5000; ++sweep) {
        double change = 0.0;
        for (const int h : holes) {
            const int col = h % grid.cols, row = h / grid.cols;
            double sum = 0.0;
            int n = 0;
            const int nbr[4][2] = {{col - 1, row}, {col + 1, row}, {col, row - 1}, {col, row + 1}};
            for (const auto& rc : nbr) {
                if (rc[0] < 0 || rc[1] < 0 || rc[0] >= grid.cols || rc[1] >= grid.rows) continue;
                const auto k = static_cast<std::size_t>(rc[1] * grid.cols + rc[0]);
                if (grid.weight[k] <= 0.0 || std::isnan(map.height[k])) continue;
                sum += map.height[k];
                ++n;
            }
            if (n == 0) continue;
            const double next = sum / n;
            change = std::max(change, std::abs(next - map.height[static_cast<std::size_t>(h)]));
            map.height[static_cast<std::size_t>(h)] = next;
        }
        if (change < 1e-7) break;
    }
    const double hole_var = 2.0 * Median(measured_var);
    for (const int h : holes) {
        map.variance[static_cast<std::size_t>(h)] = hole_var;
        map.support[static_cast<std::size_t>(h)] = 0;
    }
    map.interpolated = static_cast<int>(holes.size());
}

}  // namespace soilvol::volume
