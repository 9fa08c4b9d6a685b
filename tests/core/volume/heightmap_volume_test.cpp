#include "core/volume/heightmap_volume.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>

#include "core/cloud/ray_weights.hpp"

namespace soilvol::volume {
namespace {

using Surface = std::function<double(double, double)>;

// A rotated, non-rectangular opening so that cells are cut by slanted edges.
const Polygon2d kOpening({{-1.0, -0.35}, {0.9, -0.25}, {1.0, 0.3}, {-0.95, 0.35}});

// Random points over the opening's bounding box on `surface`, with Gaussian z noise.
Cloud Sample(const Surface& surface, std::size_t n, double sigma, unsigned seed,
             const Polygon2d& opening = kOpening) {
    std::mt19937 rng(seed);
    const Eigen::Vector2d lo = opening.Min(), hi = opening.Max();
    std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
    std::normal_distribution<double> noise(0.0, sigma);
    Cloud cloud;
    while (cloud.size() < n) {
        const double x = ux(rng), y = uy(rng);
        if (!opening.Contains({x, y})) continue;
        cloud.emplace_back(x, y, surface(x, y) + (sigma > 0 ? noise(rng) : 0.0));
    }
    return cloud;
}

// A sensor above and in front of the opening (container frame), as the simulated views.
const Eigen::Vector3d kSensor(0.0, -1.5, 1.8);

// Points seen from kSensor with their ray weights; `raw` gives every point weight 1.
std::vector<WeightedCloud> Seen(const Cloud& cloud, double sigma, bool raw = false) {
    WeightedCloud seen{cloud, {}, kSensor};
    if (!raw) seen.weights = cloud::RayWeights(cloud, kSensor, sigma, cloud::RayWeightConfig{});
    return {seen};
}

TEST(HeightmapVolumeTest, PlanarFillIsWithinThreeTenThousandthsAtEveryCellSize) {
    // Exact but for sliver cells cut by the slanted edges, where a level fit at the points'
    // centroid stands in for the plane.
    const Surface floor = [](double x, double y) { return -0.6 + 0.05 * x - 0.02 * y; };
    const Surface soil = [](double x, double y) { return -0.3 + 0.2 * x + 0.1 * y; };
    // Exact: integral of (soil - floor) = area * (0.3 + 0.15 cx + 0.12 cy) at the centroid.
    const Cloud empty = Sample(floor, 40000, 0.0, 1);
    const Cloud scan = Sample(soil, 40000, 0.0, 2);
    double ax = 0, ay = 0;
    {
        // Centroid of the opening by fine clipping.
        double area = 0;
        for (double x = -1.0; x < 1.0; x += 0.01) {
            for (double y = -0.35; y < 0.35; y += 0.01) {
                const auto [a, c] = kOpening.Clip({x, y}, {x + 0.01, y + 0.01});
                area += a;
                ax += a * c.x();
                ay += a * c.y();
            }
        }
        ax /= area;
        ay /= area;
    }
    const double expected = kOpening.Area() * (0.3 + 0.15 * ax + 0.12 * ay);
    for (const double cell : {0.03, 0.05, 0.07, 0.10, 0.12, 0.15}) {
        HeightmapConfig config;
        config.cell_m = cell;
        const auto result =
            HeightmapVolume(Seen(empty, 0.0, true), Seen(scan, 0.0, true), kOpening, config);
        ASSERT_TRUE(result.ok()) << result.status();
        EXPECT_NEAR(result->volume_m3, expected, 3e-4 * expected) << "cell " << cell;
    }
}

TEST(HeightmapVolumeTest, EmptyContainerReadsZeroWithoutPositiveBias) {
    // Model and scan are two noisy looks at the same floor (4 cm noise, ~1500 points each).
    const Surface floor = [](double, double) { return -0.6; };
    double sum = 0.0, sum_sq = 0.0;
    constexpr int kSeeds = 10;
    for (int seed = 0; seed < kSeeds; ++seed) {
        const Cloud empty = Sample(floor, 1500, 0.04, 100 + seed);
        const Cloud scan = Sample(floor, 1500, 0.04, 200 + seed);
        const auto result =
            HeightmapVolume(Seen(empty, 0.04), Seen(scan, 0.04), kOpening, HeightmapConfig{});
        ASSERT_TRUE(result.ok()) << result.status();
        sum += result->raw_volume_m3;
        sum_sq += result->raw_volume_m3 * result->raw_volume_m3;
        // Each run within 4 of its own 1-sigma: the uncertainty is honest.
        EXPECT_LT(std::abs(result->raw_volume_m3), 4.0 * result->uncertainty_m3 + 1e-4);
    }
    const double mean = sum / kSeeds;
    const double sd = std::sqrt(sum_sq / kSeeds - mean * mean);
    // Unbiased: the mean over seeds is within 3 standard errors of zero and below 1.5 litres.
    EXPECT_LT(std::abs(mean), 3.0 * sd / std::sqrt(kSeeds) + 1e-4);
    EXPECT_LT(std::abs(mean), 1.5e-3);
}

TEST(HeightmapVolumeTest, VerticalWallReturnsTellNoHeight) {
    // Box of 2.0 x 0.6 m, floor -0.6, soil -0.4, its far wall (y = 0.3) facing the sensor.
    // Every return is displaced along its ray by 2 cm noise, so the wall's returns spread into
    // the cells beside it at every height. Their ray weights are near 0: a height read off a
    // wall seen face-on moves by the whole range noise. The returns at the wall's foot, within a
    // normal's reach of the floor, still weigh: the empty wall reaches 20 cm lower than the
    // filled one, and that costs 1-2% here (the pipeline also drops returns near the container's
    // own structure). Unweighted returns read 2.5-2.8% low.
    const Polygon2d box({{-1.0, -0.3}, {1.0, -0.3}, {1.0, 0.3}, {-1.0, 0.3}});
    std::mt19937 rng(5);
    std::normal_distribution<double> noise(0.0, 0.02);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto scan = [&](double top_of_contents) {
        Cloud cloud;
        auto add = [&](const Eigen::Vector3d& p) {
            const Eigen::Vector3d q = p + noise(rng) * (p - kSensor).normalized();
            if (box.Contains(q.head<2>())) cloud.push_back(q.cast<float>());
        };
        for (int i = 0; i < 6000; ++i)
            add({-1.0 + 2.0 * u(rng), -0.3 + 0.6 * u(rng), top_of_contents});
        for (int i = 0; i < 3000; ++i) {
            add({-1.0 + 2.0 * u(rng), 0.3, top_of_contents * u(rng)});
        }
        return cloud;
    };
    const Cloud empty = scan(-0.6);
    const Cloud filled = scan(-0.4);
    const double expected = 2.0 * 0.6 * 0.2;
    for (const double cell : {0.03, 0.05, 0.10, 0.15}) {
        HeightmapConfig config;
        config.cell_m = cell;
        const auto result = HeightmapVolume(Seen(empty, 0.02), Seen(filled, 0.02), box, config);
        ASSERT_TRUE(result.ok()) << result.status();
        EXPECT_NEAR(result->volume_m3, expected, 0.02 * expected) << "cell " << cell;
    }
}

TEST(HeightmapVolumeTest, OccludedStripIsInterpolated) {
    const Surface floor = [](double, double) { return -0.6; };
    const Surface soil = [](double x, double) { return -0.4 + 0.05 * x; };
    const Cloud empty = Sample(floor, 20000, 0.0, 3);
    Cloud scan;
    for (const auto& p : Sample(soil, 20000, 0.0, 4)) {
        if (p.y() > -0.15f) scan.push_back(p);  // the near strip is hidden behind the wall
    }
    HeightmapConfig config;
    config.cell_m = 0.05;
    const auto result =
        HeightmapVolume(Seen(empty, 0.0, true), Seen(scan, 0.0, true), kOpening, config);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_GT(result->cells.interpolated, 20);
    double ax = 0, area = 0;
    for (double x = -1.0; x < 1.0; x += 0.01) {
        for (double y = -0.35; y < 0.35; y += 0.01) {
            const auto [a, c] = kOpening.Clip({x, y}, {x + 0.01, y + 0.01});
            area += a;
            ax += a * c.x();
        }
    }
    const double expected = area * (0.2 + 0.05 * ax / area);
    EXPECT_NEAR(result->volume_m3, expected, 0.005 * expected);
}

TEST(HeightmapVolumeTest, AutomaticCellSizeFollowsDensity) {
    HeightmapConfig config;
    const double sparse = AutomaticCellSize(1500, kOpening, config);
    const double dense = AutomaticCellSize(150000, kOpening, config);
    // The density target's size, within half a step (2^(1/16)) of it, on the ladder.
    const double target = std::sqrt(16.0 * kOpening.Area() / 1500);
    EXPECT_LE(std::abs(std::log2(sparse / target)), 1.0 / 16.0 + 1e-12);
    const double steps = 8.0 * std::log2(sparse / config.min_cell_m);
    EXPECT_NEAR(steps, std::round(steps), 1e-9);
    EXPECT_GT(sparse, dense);
    EXPECT_GE(dense, config.min_cell_m);
    // Scans a little denser or sparser share the grid.
    EXPECT_EQ(AutomaticCellSize(1480, kOpening, config), sparse);
    EXPECT_EQ(AutomaticCellSize(1520, kOpening, config), sparse);
}

// However dense the scan, the automatic grid stays within max_cells; an explicit cell past it is
// refused by name before anything is allocated for it.
TEST(HeightmapVolumeTest, GridsStayWithinTheCellBudget) {
    HeightmapConfig config;
    const Polygon2d wagon({{-12.5, -2.0}, {12.5, -2.0}, {12.5, 2.0}, {-12.5, 2.0}});
    const double cell = AutomaticCellSize(50000000, wagon, config);
    EXPECT_LE(GridCells(wagon, cell), config.max_cells);
    EXPECT_GT(GridCells(wagon, cell), 0.5 * config.max_cells);
    config.cell_m = 0.005;  // 16 million cells over the wagon
    const Cloud empty = Sample([](double, double) { return -0.6; }, 2000, 0.0, 1, wagon);
    const Cloud scan = Sample([](double, double) { return -0.3; }, 2000, 0.0, 2, wagon);
    const auto result =
        HeightmapVolume(Seen(empty, 0.0, true), Seen(scan, 0.0, true), wagon, config);
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(result.status().message().find("grid_cell_m"), std::string::npos) << result.status();
}

TEST(HeightmapVolumeTest, NoScanPointsIsFailedPrecondition) {
    const Cloud empty = Sample([](double, double) { return -0.6; }, 2000, 0.0, 1);
    const auto result =
        HeightmapVolume(Seen(empty, 0.0, true), std::vector<WeightedCloud>{WeightedCloud{}},
                        kOpening, HeightmapConfig{});
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace soilvol::volume

namespace soilvol::volume {
namespace {

TEST(HeightmapVolumeTest, ScanBelowTheEmptySurfaceIsCountedCellByCell) {
    // Soil never lies below the container: a scan 10 cm under the floor (4 noise sigmas of
    // 2.5 cm) is what a wrong pose gives, and nearly every cell says so; a right one, almost none.
    const Surface floor = [](double, double) { return -0.6; };
    const Cloud empty = Sample(floor, 20000, 0.025, 21);
    HeightmapConfig config;
    config.cell_m = 0.1;
    const auto sunk =
        HeightmapVolume(Seen(empty, 0.025),
                        Seen(Sample([](double, double) { return -0.7; }, 20000, 0.025, 22), 0.025),
                        kOpening, config);
    ASSERT_TRUE(sunk.ok()) << sunk.status();
    EXPECT_GT(sunk->cells.below_empty, 0.9 * sunk->cells.both_measured);
    const auto right = HeightmapVolume(
        Seen(empty, 0.025), Seen(Sample(floor, 20000, 0.025, 23), 0.025), kOpening, config);
    ASSERT_TRUE(right.ok()) << right.status();
    EXPECT_LT(right->cells.below_empty, 0.02 * right->cells.both_measured);
}

}  // namespace
}  // namespace soilvol::volume

namespace soilvol::volume {
namespace {

// A strip of the opening the scan did not see (its rays pass over it to the soil beyond): the
// soil there lies between the empty surface and those rays, and that range is in the
// uncertainty. Seen everywhere, nothing is unobserved.
TEST(HeightmapVolumeTest, HiddenStripOfSoilCarriesItsRangeAsUncertainty) {
    const Surface floor = [](double, double) { return -0.6; };
    const Surface soil = [](double, double) { return -0.4; };
    const Cloud empty = Sample(floor, 20000, 0.0, 5);
    const Cloud full = Sample(soil, 20000, 0.0, 6);
    Cloud scan;
    for (const auto& p : full) {
        if (p.y() > -0.15f) scan.push_back(p);
    }
    HeightmapConfig config;
    config.cell_m = 0.05;
    const auto seen_all = HeightmapVolume(Seen(empty, 0.0), Seen(full, 0.0), kOpening, config);
    ASSERT_TRUE(seen_all.ok()) << seen_all.status();
    EXPECT_LT(seen_all->unobserved_uncertainty_m3, 0.001);  // a few cut edge cells
    const auto hidden = HeightmapVolume(Seen(empty, 0.0), Seen(scan, 0.0), kOpening, config);
    ASSERT_TRUE(hidden.ok()) << hidden.status();
    // The strip is about 1.9 m x 0.2 m; the rays over it run from the soil's height up to
    // about 30 cm above it (from kSensor), 20-50 cm above the floor.
    const double strip_m2 = 1.9 * 0.2;
    EXPECT_GT(hidden->unobserved_uncertainty_m3, strip_m2 * 0.1 / std::sqrt(12.0));
    EXPECT_LT(hidden->unobserved_uncertainty_m3, strip_m2 * 0.6 / std::sqrt(12.0));
    // The continued soil is right here; the truth lies within the reported range.
    EXPECT_NEAR(hidden->volume_m3, seen_all->volume_m3, 2.0 * hidden->uncertainty_m3);
}

// Soil stands no steeper than the heap slope (1:1), so a wide hidden band along the near wall
// ranges only slope x distance around its seen edge, not from the floor to the rays over it.
TEST(HeightmapVolumeTest, HiddenBandRangesNoSteeperThanTheHeapSlopeFromItsSeenEdge) {
    const Surface floor = [](double, double) { return -0.6; };
    const Surface soil = [](double x, double) { return -0.4 + 0.05 * x; };
    const Cloud empty = Sample(floor, 20000, 0.0, 5);
    const Cloud full = Sample(soil, 20000, 0.0, 6);
    constexpr double kEdge = 0.05;  // the scan sees y > kEdge only
    Cloud scan;
    for (const auto& p : full) {
        if (p.y() > static_cast<float>(kEdge)) scan.push_back(p);
    }
    HeightmapConfig config;
    config.cell_m = 0.05;
    const auto hidden = HeightmapVolume(Seen(empty, 0.0), Seen(scan, 0.0), kOpening, config);
    ASSERT_TRUE(hidden.ok()) << hidden.status();
    // The band is about 1.9 m long and 0.35-0.4 m wide: a range of 2 x slope x distance to the
    // edge integrates to 2 / sqrt(12) x L x W^2 / 2; floor to rays would be about 0.14 m^3.
    const double bound = 2.0 / std::sqrt(12.0) * 1.9 * 0.4 * 0.4 / 2.0;
    EXPECT_LT(hidden->unobserved_uncertainty_m3, bound);
    EXPECT_GT(hidden->unobserved_uncertainty_m3, 0.1 * bound);
    const auto seen_all = HeightmapVolume(Seen(empty, 0.0), Seen(full, 0.0), kOpening, config);
    ASSERT_TRUE(seen_all.ok()) << seen_all.status();
    EXPECT_NEAR(hidden->volume_m3, seen_all->volume_m3, 2.0 * hidden->uncertainty_m3);
}

// Cells finer than the returns' spacing are interpolated between samples, not unseen.
TEST(HeightmapVolumeTest, CellsFinerThanTheSpacingAreNotUnobserved) {
    const Surface floor = [](double, double) { return -0.6; };
    const Surface soil = [](double, double) { return -0.4; };
    HeightmapConfig config;
    config.cell_m = 0.01;  // the returns lie about 2.5 cm apart
    const auto result = HeightmapVolume(Seen(Sample(floor, 2000, 0.0, 7), 0.0),
                                        Seen(Sample(soil, 2000, 0.0, 8), 0.0), kOpening, config);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_GT(result->cells.interpolated, result->cells.total / 4);
    EXPECT_LT(result->unobserved_uncertainty_m3, 0.002);
}

// The volume's pose gradient against what a rigid motion of the scan does to a heightfield.
VolumeResult SurfaceResult(const Polygon2d& opening, double cell_m,
                           const std::function<double(double, double)>& f) {
    VolumeResult r;
    r.grid = MakeGrid(opening, cell_m);
    r.scan_surface_m.assign(r.grid.weight.size(), std::numeric_limits<double>::quiet_NaN());
    for (std::size_t k = 0; k < r.grid.weight.size(); ++k) {
        if (r.grid.weight[k] > 0.0)
            r.scan_surface_m[k] = f(r.grid.anchor[k].x(), r.grid.anchor[k].y());
    }
    return r;
}

TEST(VolumePoseGradientTest, FlatSurfaceMovesWithTheShiftAndTheTilt) {
    // A flat surface over [1, 2] x [-0.5, 0.5]. A point truly lies at p - t, so the true surface
    // is t_z lower: dV/dt_z = -area.
    const Polygon2d opening({{1.0, -0.5}, {2.0, -0.5}, {2.0, 0.5}, {1.0, 0.5}});
    const auto g =
        VolumePoseGradient(SurfaceResult(opening, 0.05, [](double, double) { return -0.3; }));
    EXPECT_NEAR(g(5), -1.0, 1e-9);
    EXPECT_NEAR(g(3), 0.0, 1e-9);
    EXPECT_NEAR(g(4), 0.0, 1e-9);
    // A rotation w about y lifts each point by w x (p - w x p has z + w x): dV/dw_y = sum x dA.
    EXPECT_NEAR(g(1), 1.5, 1e-9);
    EXPECT_NEAR(g(0), 0.0, 1e-9);  // symmetric in y
    EXPECT_NEAR(g(2), 0.0, 1e-9);  // a turn about z slides a flat surface along itself
}

TEST(VolumePoseGradientTest, LateralShiftMovesAStepThroughItsCells) {
    // A 0.4 m step down at x = 0 across a 1 m wide opening: the true surface is the measured one
    // moved by -t, F(x + t_x), so dV/dt_x = integral of dF/dx = -0.4 m x 1 m.
    const Polygon2d opening({{-1.0, -0.5}, {1.0, -0.5}, {1.0, 0.5}, {-1.0, 0.5}});
    const auto g = VolumePoseGradient(
        SurfaceResult(opening, 0.05, [](double x, double) { return x < 0.0 ? -0.2 : -0.6; }));
    EXPECT_NEAR(g(3), -0.4, 0.02);
    EXPECT_NEAR(g(4), 0.0, 1e-9);
}

}  // namespace
}  // namespace soilvol::volume
