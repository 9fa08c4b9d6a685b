#include "core/volume/heightmap_volume.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

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
        const auto result = HeightmapVolume(empty, scan, kOpening, config);
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
        const auto result = HeightmapVolume(empty, scan, kOpening, HeightmapConfig{});
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

TEST(HeightmapVolumeTest, WallPointsLeakingIntoCellsDoNotRaiseTheSurface) {
    // Box of 2.0 x 0.6 m, floor -0.6, soil -0.4; noisy vertical walls at the boundary spread
    // 3 cm into the cells (the far wall faces the sensor and is dense).
    const Polygon2d box({{-1.0, -0.3}, {1.0, -0.3}, {1.0, 0.3}, {-1.0, 0.3}});
    std::mt19937 rng(5);
    std::normal_distribution<double> n(0.0, 0.03);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    auto walls = [&](Cloud& cloud, double top_of_contents) {
        for (int i = 0; i < 4000; ++i) {
            const double z = top_of_contents + u(rng) * (0.0 - top_of_contents);
            cloud.emplace_back(-1.0 + 2.0 * u(rng), 0.3 - std::abs(n(rng)), z);
        }
    };
    Cloud empty = Sample([](double, double) { return -0.6; }, 3000, 0.02, 11, box);
    walls(empty, -0.6);
    Cloud scan = Sample([](double, double) { return -0.4; }, 3000, 0.02, 12, box);
    walls(scan, -0.4);
    const double expected = 2.0 * 0.6 * 0.2;
    for (const double cell : {0.03, 0.05, 0.10, 0.15}) {
        HeightmapConfig config;
        config.cell_m = cell;
        const auto result = HeightmapVolume(empty, scan, box, config);
        ASSERT_TRUE(result.ok()) << result.status();
        EXPECT_NEAR(result->volume_m3, expected, 0.01 * expected) << "cell " << cell;
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
    const auto result = HeightmapVolume(empty, scan, kOpening, config);
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
    EXPECT_NEAR(sparse, std::sqrt(16.0 * kOpening.Area() / 1500), 1e-12);
    EXPECT_GT(sparse, dense);
    EXPECT_GE(dense, config.min_cell_m);
}

TEST(HeightmapVolumeTest, NoScanPointsIsFailedPrecondition) {
    const Cloud empty = Sample([](double, double) { return -0.6; }, 2000, 0.0, 1);
    const auto result = HeightmapVolume(empty, Cloud{}, kOpening, HeightmapConfig{});
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace soilvol::volume
