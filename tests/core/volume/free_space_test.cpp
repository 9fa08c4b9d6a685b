#include "core/volume/free_space.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace soilvol::volume {
namespace {

// A 1 x 1 m opening over a floor at -0.5 m; the sensor stands above the -y edge.
const Polygon2d kSquareOpening({{-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}});

TEST(FreeSpaceTest, RaysBoundTheSurfaceFromAboveAlongTheirPath) {
    const Grid grid = MakeGrid(kSquareOpening, 0.1);
    WeightedCloud scan;
    scan.sensor = Eigen::Vector3d(0.0, -1.5, 1.0);
    // Returns on the floor's far half only; their rays pass over the near half.
    for (double x = -0.45; x < 0.5; x += 0.02) {
        for (double y = 0.05; y < 0.5; y += 0.02) scan.points.emplace_back(x, y, -0.5);
    }
    const std::vector<double> ceiling = FreeSpaceCeiling(grid, {scan});
    // Over the near half, every ray is above the floor and below the sensor's height.
    const int near = grid.CellOf(0.0, -0.2);
    ASSERT_GE(near, 0);
    EXPECT_TRUE(std::isfinite(ceiling[static_cast<std::size_t>(near)]));
    EXPECT_GT(ceiling[static_cast<std::size_t>(near)], -0.5);
    EXPECT_LT(ceiling[static_cast<std::size_t>(near)], 1.0);
    // The lowest ray over (0, -0.2) runs to the nearest return at y = 0.05: its height there
    // follows the line from the sensor, within a cell's step.
    const double t = (-0.2 - scan.sensor.y()) / (0.05 - scan.sensor.y());
    const double expected = scan.sensor.z() + t * (-0.5 - scan.sensor.z());
    EXPECT_NEAR(ceiling[static_cast<std::size_t>(near)], expected, 0.08);
    // Beside the returns' own cell no ray passes within a cell: nothing bounds the far edge.
    const int far = grid.CellOf(0.0, 0.47);
    EXPECT_FALSE(std::isfinite(ceiling[static_cast<std::size_t>(far)]));
}

TEST(FreeSpaceTest, OneStrayReturnDoesNotLowerACeiling) {
    const Grid grid = MakeGrid(kSquareOpening, 0.1);
    WeightedCloud scan;
    scan.sensor = Eigen::Vector3d(0.0, 0.0, 2.0);
    scan.points.emplace_back(0.45, 0.0, -3.0);  // a return far below everything
    const std::vector<double> ceiling = FreeSpaceCeiling(grid, {scan});
    for (const double c : ceiling) EXPECT_FALSE(std::isfinite(c));
}

TEST(FreeSpaceTest, ScansAddTheirRays) {
    const Grid grid = MakeGrid(kSquareOpening, 0.1);
    WeightedCloud a, b;
    a.sensor = Eigen::Vector3d(0.0, -1.5, 1.0);
    b.sensor = Eigen::Vector3d(0.0, 1.5, 1.0);
    for (double x = -0.45; x < 0.5; x += 0.05) {
        a.points.emplace_back(x, 0.45, -0.5);
        b.points.emplace_back(x, -0.45, -0.5);
    }
    const auto one = FreeSpaceCeiling(grid, {a});
    const auto both = FreeSpaceCeiling(grid, {a, b});
    int lowered = 0;
    for (std::size_t k = 0; k < one.size(); ++k) {
        EXPECT_LE(both[k], one[k]);
        if (both[k] < one[k]) ++lowered;
    }
    EXPECT_GT(lowered, 10);
}

}  // namespace
}  // namespace soilvol::volume
