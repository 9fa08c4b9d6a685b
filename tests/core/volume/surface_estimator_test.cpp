#include "core/volume/surface_estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace soilvol::volume {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kSigmaM = 0.01;  // range noise of the synthetic returns
constexpr double kCellM = 0.1;

// z = a + b x + c y [m].
struct Plane {
    double a = 0.0, b = 0.0, c = 0.0;
    double At(const Eigen::Vector2d& xy) const { return a + b * xy.x() + c * xy.y(); }
};

Polygon2d Rectangle(double x0, double y0, double width, double height) {
    return Polygon2d({{x0, y0}, {x0 + width, y0}, {x0 + width, y0 + height}, {x0, y0 + height}});
}

// `count` returns spread uniformly over the opening's bounding box, kept where inside the
// opening and where `keep` (if given) says so, at the plane's height plus N(0, sigma).
Cloud SamplePlane(const Polygon2d& opening, const Plane& plane, int count, double sigma,
                  uint64_t seed, const std::function<bool(const Eigen::Vector2d&)>& keep = {}) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> ux(opening.Min().x(), opening.Max().x());
    std::uniform_real_distribution<double> uy(opening.Min().y(), opening.Max().y());
    std::normal_distribution<double> noise(0.0, sigma);
    Cloud cloud;
    for (int i = 0; i < count; ++i) {
        const Eigen::Vector2d xy(ux(rng), uy(rng));
        const double z = plane.At(xy) + noise(rng);
        if (!opening.Contains(xy) || (keep && !keep(xy))) continue;
        cloud.emplace_back(static_cast<float>(xy.x()), static_cast<float>(xy.y()),
                           static_cast<float>(z));
    }
    return cloud;
}

// Standard error [m] of a cell's height fitted from n returns of noise sigma: the intercept of a
// plane fit at the returns' centroid has variance sigma^2 / n_eff. The window's Gaussian kernel
// (sigma half a cell) over a uniformly covered cell keeps n_eff / n = E[w]^2 / E[w^2] = 0.96, and
// Tukey's biweight at 4.685 sigmas is 95% efficient: n_eff >= 0.9 n.
double HeightStandardError(double sigma, int n) { return sigma / std::sqrt(0.9 * n); }

// 5 standard errors: over the ~100 cells of a test, a true estimator strays past it with
// probability ~100 x 6e-7.
constexpr double kSigmas = 5.0;

int MinSupport(const Grid& grid, const SurfaceMap& map) {
    int n = std::numeric_limits<int>::max();
    for (int k = 0; k < grid.NumCells(); ++k) {
        if (map.support[static_cast<std::size_t>(k)] > 0) {
            n = std::min(n, map.support[static_cast<std::size_t>(k)]);
        }
    }
    return n;
}

TEST(SurfaceEstimatorTest, FlatPlaneHeightsLieWithinFiveStandardErrorsOfTheTruth) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{0.5, 0.0, 0.0};
    const Cloud cloud = SamplePlane(opening, plane, 20000, kSigmaM, 1);
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    EXPECT_EQ(map->measured, grid.NumCells());
    EXPECT_EQ(map->interpolated, 0);
    EXPECT_EQ(map->window_cells, 1);  // 20000 returns/m^2 put 12 within 2.5 cm
    // The noise estimate is a median over 100 windows of a MAD (relative sd 1.17 / sqrt(200) per
    // window): 5% is more than 5 of its standard errors.
    EXPECT_NEAR(map->noise_sigma_m, kSigmaM, 0.05 * kSigmaM);
    double normalised_sq = 0.0;
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        ASSERT_GT(map->support[i], 0) << k;
        const double truth = plane.At(grid.anchor[i]);
        EXPECT_NEAR(map->height[i], truth, kSigmas * HeightStandardError(kSigmaM, map->support[i]))
            << "cell " << k;
        normalised_sq += std::pow(map->height[i] - truth, 2) / map->variance[i];
        EXPECT_NEAR(map->observed[i], 1.0, 1e-12) << k;
        // A plane leaves nothing out: the misfit is noise alone (the median of ~200 squared
        // residuals reads the variance to 16%, so sqrt(0.5) sigma at 3 of its standard errors).
        EXPECT_LE(map->misfit[i], kSigmaM) << k;
    }
    // The variances are the heights' own: the mean of 100 squared errors over their variance
    // is 1 +- 0.14 (chi-square with 100 degrees of freedom, divided by 100); 0.5..1.6 is 3.5 sd.
    const double mean_normalised = normalised_sq / grid.NumCells();
    EXPECT_GT(mean_normalised, 0.5);
    EXPECT_LT(mean_normalised, 1.6);
}

// A tilted plane over a trapezoid whose slanted side cuts cells: each height is the plane at the
// cell's anchor (the centroid of its part inside the opening), and cells wholly outside the
// opening are NaN even where returns lie.
TEST(SurfaceEstimatorTest, TiltedPlaneIsReadAtEachCellsAnchor) {
    const Polygon2d opening({{0.2, -0.3}, {1.2, -0.3}, {1.2, 0.7}, {0.2, 0.2}});
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{0.3, 0.25, -0.15};
    // Returns cover the opening's bounding box: those outside the opening give no cell a height.
    const Cloud cloud = SamplePlane(Rectangle(0.2, -0.3, 1.0, 1.0), plane, 20000, kSigmaM, 2);
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    int outside = 0, checked = 0;
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        if (grid.weight[i] <= 0.0) {
            ++outside;
            EXPECT_TRUE(std::isnan(map->height[i])) << "cell " << k << " is outside the opening";
            EXPECT_EQ(map->support[i], 0);
            continue;
        }
        if (map->support[i] == 0) continue;  // a sliver too thin to be measured: filled
        ++checked;
        const double truth = plane.At(grid.anchor[i]);
        // Slivers of a few returns: the plane fit there is a level or a 3-point fit, off by the
        // slope times the returns' spread from the anchor (< 1 cell x 0.29), so they get 3 sigma
        // of a single return on top.
        const double tolerance = kSigmas * HeightStandardError(kSigmaM, map->support[i]) +
                                 (map->support[i] < 30 ? 3.0 * kSigmaM : 0.0);
        EXPECT_NEAR(map->height[i], truth, tolerance) << "cell " << k;
    }
    // 70 cells lie wholly inside, 10 are cut by the slanted side and 20 lie wholly outside.
    EXPECT_EQ(outside, 20);
    EXPECT_EQ(checked, 80);
}

// A ridge z = 0.5 - s |x - x0| along the middle of a column of cells: the plane of a cell the
// ridge halves leaves out the roof's two faces. For returns uniform over a cell of side h with the
// ridge through its centre, the best plane is the level s h / 4 below the ridge and the faces
// stray from it by s h sqrt(1/12 - 1/16) = 0.144 s h RMS, s h / 4 at most: 2.9 cm and 5 cm for
// s = 2 (63 deg) and h = 10 cm, over 1 cm of noise. Cells the ridge does not cross are planes.
TEST(SurfaceEstimatorTest, MisfitIsWhatACellsPlaneLeavesOutOfARidge) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    constexpr double kSlope = 2.0, kRidgeX = 0.45;  // the middle of the fifth column of cells
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::normal_distribution<double> noise(0.0, kSigmaM);
    Cloud cloud;
    for (int i = 0; i < 20000; ++i) {
        const double x = u(rng), y = u(rng);
        cloud.emplace_back(static_cast<float>(x), static_cast<float>(y),
                           static_cast<float>(0.5 - kSlope * std::abs(x - kRidgeX) + noise(rng)));
    }
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        ASSERT_GT(map->support[i], 0) << k;
        if (k % grid.cols == 4) {  // the ridge's column
            EXPECT_GT(map->misfit[i], 0.5 * 0.144 * kSlope * kCellM) << k;
            EXPECT_LT(map->misfit[i], kSlope * kCellM / 4.0) << k;
        } else {
            EXPECT_LE(map->misfit[i], kSigmaM) << k;
        }
    }
}

TEST(SurfaceEstimatorTest, GrossOutliersAboveTheSurfaceDoNotMoveIt) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{0.0, 0.1, 0.05};
    Cloud cloud = SamplePlane(opening, plane, 20000, kSigmaM, 3);
    const auto inliers = static_cast<int>(cloud.size());
    // 5% dust and spoil spill 0.3-0.6 m above the surface (30-60 sigma): a least-squares fit
    // would read 2-3 cm high, far beyond the tolerance.
    std::mt19937_64 rng(4);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::uniform_real_distribution<double> up(0.3, 0.6);
    for (int i = 0; i < inliers / 20; ++i) {
        const Eigen::Vector2d xy(u(rng), u(rng));
        cloud.emplace_back(static_cast<float>(xy.x()), static_cast<float>(xy.y()),
                           static_cast<float>(plane.At(xy) + up(rng)));
    }
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        // Standard error from the cell's inliers (support counts the outliers too: 1/21 of it).
        const int n = map->support[i] * 20 / 21;
        EXPECT_NEAR(map->height[i], plane.At(grid.anchor[i]),
                    kSigmas * HeightStandardError(kSigmaM, n))
            << "cell " << k;
    }
}

// Returns of weight 0 (a vertical wall's, whose height reading says nothing) do not move the
// surface even when they outnumber the others.
TEST(SurfaceEstimatorTest, ReturnsOfWeightZeroTellNothing) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane floor{0.2, 0.0, 0.0};
    Cloud cloud = SamplePlane(opening, floor, 20000, kSigmaM, 5);
    std::vector<float> weights(cloud.size(), 1.0f);
    const Cloud smear = SamplePlane(opening, Plane{0.5, 0.0, 0.0}, 30000, kSigmaM, 6);
    cloud.insert(cloud.end(), smear.begin(), smear.end());
    weights.resize(cloud.size(), 0.0f);
    const auto map = EstimateSurface(grid, cloud, weights, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        // ~40% of the cell's support carries weight 1.
        const int n = map->support[i] * 2 / 5;
        EXPECT_NEAR(map->height[i], floor.a, kSigmas * HeightStandardError(kSigmaM, n)) << k;
    }
}

// A square hole of 3 x 3 cells inside a tilted plane, and one on its edge, are filled to the
// plane they lie in: the measured cells around continue it (a membrane would flatten the one on
// the edge, off by the slope x 1-3 cells = 1.5-4.5 cm). The fill averages several measured
// cells, so it is no farther off than a measured height: 5 of the worst cell's standard errors.
TEST(SurfaceEstimatorTest, HolesAreFilledToThePlaneTheyLieIn) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{0.4, 0.25, 0.15};
    const auto in_block = [](const Eigen::Vector2d& p, double x0, double y0) {
        return p.x() >= x0 && p.x() < x0 + 0.3 && p.y() >= y0 && p.y() < y0 + 0.3;
    };
    const Cloud cloud = SamplePlane(
        opening, plane, 20000, kSigmaM, 7,
        [&](const Eigen::Vector2d& p) { return !in_block(p, 0.1, 0.2) && !in_block(p, 0.4, 0.7); });
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    EXPECT_EQ(map->interpolated, 18);
    EXPECT_EQ(map->measured, grid.NumCells() - 18);
    std::vector<double> measured_var;
    for (int k = 0; k < grid.NumCells(); ++k) {
        if (map->support[static_cast<std::size_t>(k)] > 0) {
            measured_var.push_back(map->variance[static_cast<std::size_t>(k)]);
        }
    }
    std::nth_element(measured_var.begin(), measured_var.begin() + measured_var.size() / 2,
                     measured_var.end());
    const double hole_variance = 2.0 * measured_var[measured_var.size() / 2];
    const double tolerance = kSigmas * HeightStandardError(kSigmaM, MinSupport(grid, *map));
    int holes = 0;
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        const Eigen::Vector2d centre = grid.Center(k);
        const bool hole = in_block(centre, 0.1, 0.2) || in_block(centre, 0.4, 0.7);
        if (!hole) continue;
        ++holes;
        EXPECT_EQ(map->support[i], 0) << "cell " << k;
        EXPECT_EQ(map->observed[i], 0.0) << "cell " << k;
        EXPECT_NEAR(map->height[i], plane.At(grid.anchor[i]), tolerance) << "cell " << k;
        EXPECT_DOUBLE_EQ(map->variance[i], hole_variance) << "cell " << k;
    }
    EXPECT_EQ(holes, 18);
}

// FillHoles on its own: an exact plane of measured cells is continued exactly into the holes
// (a weighted least-squares plane reproduces a plane to rounding), cells outside the opening
// stay NaN.
TEST(SurfaceEstimatorTest, FillHolesContinuesAnExactPlaneToRounding) {
    const Polygon2d opening({{0.0, 0.0}, {1.0, 0.0}, {1.0, 0.55}, {0.0, 1.0}});
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{-0.2, 0.3, -0.4};
    SurfaceMap map;
    const auto n = static_cast<std::size_t>(grid.NumCells());
    map.height.assign(n, kNaN);
    map.variance.assign(n, kNaN);
    map.support.assign(n, 0);
    std::vector<int> holes;
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        if (grid.weight[i] <= 0.0) continue;
        if (k % 7 == 0 || (k % grid.cols >= 6 && k / grid.cols >= 4)) {
            holes.push_back(k);
            continue;
        }
        map.height[i] = plane.At(grid.anchor[i]);
        map.variance[i] = 1e-6;
        map.support[i] = 10;
    }
    ASSERT_GT(holes.size(), 10u);
    FillHoles(grid, map);
    EXPECT_EQ(map.interpolated, static_cast<int>(holes.size()));
    for (const int k : holes) {
        const auto i = static_cast<std::size_t>(k);
        EXPECT_NEAR(map.height[i], plane.At(grid.anchor[i]), 1e-9) << "cell " << k;
        EXPECT_EQ(map.variance[i], 2e-6);
        EXPECT_EQ(map.support[i], 0);
    }
    for (int k = 0; k < grid.NumCells(); ++k) {
        if (grid.weight[static_cast<std::size_t>(k)] <= 0.0) {
            EXPECT_TRUE(std::isnan(map.height[static_cast<std::size_t>(k)])) << "cell " << k;
        }
    }
}

// A strip of cells with fewer than 6 measured: every hole still takes a height (a level
// through the measured ones), whatever the strip's length.
TEST(SurfaceEstimatorTest, FillHolesFillsEveryHoleFromFewMeasuredCells) {
    for (const int cols : {2, 3, 5, 6, 7, 12, 40}) {
        const Grid grid = MakeGrid(Rectangle(0.0, 0.0, cols * kCellM, kCellM), kCellM);
        ASSERT_EQ(grid.cols, cols);
        SurfaceMap map;
        const auto n = static_cast<std::size_t>(grid.NumCells());
        map.height.assign(n, kNaN);
        map.variance.assign(n, kNaN);
        map.support.assign(n, 0);
        map.height[0] = 0.7;
        map.variance[0] = 1e-6;
        map.support[0] = 5;
        FillHoles(grid, map);
        EXPECT_EQ(map.interpolated, cols - 1) << cols << " cells";
        for (std::size_t i = 1; i < n; ++i) {
            EXPECT_NEAR(map.height[i], 0.7, 1e-12) << cols << " cells, cell " << i;
        }
    }
}

TEST(SurfaceEstimatorTest, FillHolesWithoutMeasuredCellsOrWhenStoppedLeavesHoles) {
    const Grid grid = MakeGrid(Rectangle(0.0, 0.0, 0.5, 0.5), kCellM);
    const auto n = static_cast<std::size_t>(grid.NumCells());
    SurfaceMap none;
    none.height.assign(n, kNaN);
    none.variance.assign(n, kNaN);
    none.support.assign(n, 0);
    FillHoles(grid, none);
    EXPECT_EQ(none.interpolated, 0);
    EXPECT_TRUE(std::all_of(none.height.begin(), none.height.end(),
                            [](double h) { return std::isnan(h); }));

    SurfaceMap stopped = none;
    stopped.height[0] = 1.0;
    stopped.variance[0] = 1e-6;
    stopped.support[0] = 5;
    const StopToken expired(StopToken::Clock::now() - std::chrono::seconds(1));
    FillHoles(grid, stopped, expired);
    EXPECT_TRUE(std::isnan(stopped.height[1]));
}

TEST(SurfaceEstimatorTest, NoMeasurableCellIsFailedPrecondition) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    EXPECT_EQ(EstimateSurface(grid, {}, {}, SurfaceConfig{}).status().code(),
              absl::StatusCode::kFailedPrecondition);
    // Every return outside the grid, or off it at non-finite xy.
    const Cloud outside = SamplePlane(Rectangle(2.0, 2.0, 1.0, 1.0), Plane{}, 2000, kSigmaM, 8);
    EXPECT_EQ(EstimateSurface(grid, outside, {}, SurfaceConfig{}).status().code(),
              absl::StatusCode::kFailedPrecondition);
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    const Cloud non_finite(300, Eigen::Vector3f(nan, 0.5f, 0.0f));
    Cloud mixed(non_finite);
    mixed.insert(mixed.end(), 300, Eigen::Vector3f(0.5f, inf, 0.0f));
    mixed.insert(mixed.end(), 300, Eigen::Vector3f(-inf, 0.5f, 0.0f));
    EXPECT_EQ(EstimateSurface(grid, mixed, {}, SurfaceConfig{}).status().code(),
              absl::StatusCode::kFailedPrecondition);
}

// Returns at a finite place with a non-finite height (a decoder's NaN, an overflowed range).
TEST(SurfaceEstimatorTest, NonFiniteHeightsDoNotReachTheSurface) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Plane plane{0.1, 0.0, 0.0};
    Cloud cloud = SamplePlane(opening, plane, 20000, kSigmaM, 11);
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const float bad[] = {std::numeric_limits<float>::quiet_NaN(),
                         std::numeric_limits<float>::infinity(),
                         -std::numeric_limits<float>::infinity()};
    for (int i = 0; i < 300; ++i) cloud.emplace_back(u(rng), u(rng), bad[i % 3]);
    const auto map = EstimateSurface(grid, cloud, {}, SurfaceConfig{});
    ASSERT_TRUE(map.ok()) << map.status();
    EXPECT_TRUE(std::isfinite(map->noise_sigma_m));
    for (int k = 0; k < grid.NumCells(); ++k) {
        const auto i = static_cast<std::size_t>(k);
        EXPECT_NEAR(map->height[i], plane.a, kSigmas * HeightStandardError(kSigmaM, 150)) << k;
        EXPECT_TRUE(std::isfinite(map->variance[i])) << k;
    }
}

TEST(SurfaceEstimatorTest, WeightsThatDoNotMatchThePointsAreInvalidArgument) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Cloud cloud = SamplePlane(opening, Plane{}, 2000, kSigmaM, 9);
    const std::vector<float> weights(cloud.size() - 1, 1.0f);
    EXPECT_EQ(EstimateSurface(grid, cloud, weights, SurfaceConfig{}).status().code(),
              absl::StatusCode::kInvalidArgument);
}

TEST(SurfaceEstimatorTest, AStoppedTokenEndsTheFitWithItsStatus) {
    const Polygon2d opening = Rectangle(0.0, 0.0, 1.0, 1.0);
    const Grid grid = MakeGrid(opening, kCellM);
    const Cloud cloud = SamplePlane(opening, Plane{}, 2000, kSigmaM, 10);
    const StopToken expired(StopToken::Clock::now() - std::chrono::seconds(1));
    EXPECT_EQ(EstimateSurface(grid, cloud, {}, SurfaceConfig{}, expired).status().code(),
              absl::StatusCode::kDeadlineExceeded);
    const StopToken cancelled(StopToken::Clock::time_point::max(), [] { return true; });
    EXPECT_EQ(EstimateSurface(grid, cloud, {}, SurfaceConfig{}, cancelled).status().code(),
              absl::StatusCode::kCancelled);
}

// The model cache keys empty surfaces by the config: every field must take part.
TEST(SurfaceEstimatorTest, ConfigsDifferingInAnyFieldAreUnequal) {
    const std::vector<std::function<void(SurfaceConfig&)>> changes = {
        [](SurfaceConfig& c) { c.min_window_points += 1.0; },
        [](SurfaceConfig& c) { c.max_window_cells += 2; },
        [](SurfaceConfig& c) { c.tukey_sigmas += 0.5; },
        [](SurfaceConfig& c) { c.robust_iterations += 1; },
        [](SurfaceConfig& c) { c.min_observed_fraction += 0.1; },
        [](SurfaceConfig& c) { c.max_slope += 1.0; },
        [](SurfaceConfig& c) { c.min_noise_m += 0.001; },
        [](SurfaceConfig& c) { c.default_noise_m += 0.001; },
        [](SurfaceConfig& c) { c.num_threads += 1; },
    };
    EXPECT_TRUE(SurfaceConfig{} == SurfaceConfig{});
    for (std::size_t i = 0; i < changes.size(); ++i) {
        SurfaceConfig changed;
        changes[i](changed);
        EXPECT_FALSE(changed == SurfaceConfig{}) << "field " << i;
    }
}

}  // namespace
}  // namespace soilvol::volume
