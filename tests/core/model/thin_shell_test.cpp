#include "core/model/thin_shell.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/model/opening.hpp"

namespace soilvol::model {
namespace {

// A 2 x 1 m opening; the front wall (edge 0, at y = -0.5) leans in: its inner face runs from
// the edge at the rim to `lean` m inside it at depth `depth`; the wall is `thickness` m thick
// (horizontally). The sensor stands in front of it.
const Polygon2d kWallOpening({{-1.0, -0.5}, {1.0, -0.5}, {1.0, 0.5}, {-1.0, 0.5}});
const Eigen::Vector3d kSensorInFront(0.0, -2.5, 2.0);
constexpr double kDepth = 0.8;

// The outside returns of that wall, with range noise along the rays, and a flange standing out
// 6 cm at the rim (its top 4 cm).
Cloud FrontWallOutside(double lean, double thickness, double noise, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, noise);
    Cloud out;
    for (double x = -0.9; x <= 0.9; x += 0.02) {
        for (double z = -0.01; z > -kDepth; z -= 0.02) {
            const bool flange = z > -0.04;
            const double inward = flange ? -0.06 : -thickness + lean * (-z) / kDepth;
            const Eigen::Vector3d p(x, -0.5 + inward, z);
            const Eigen::Vector3d q = p + n(rng) * (p - kSensorInFront).normalized();
            out.push_back(q.cast<float>());
        }
    }
    return out;
}

TEST(ThinShellTest, LeaningWallSeenFromOutsideGivesItsThicknessAndInnerFace) {
    const Cloud outside = FrontWallOutside(0.10, 0.03, 0.02, 1);
    const std::vector<WallPrior> walls =
        InnerFaceFromOutside(outside, kSensorInFront, kWallOpening);
    ASSERT_EQ(walls.size(), 1u);
    EXPECT_EQ(walls[0].edge, 0);
    // The returns' noise along the rays moves the profile's medians by a few millimetres.
    EXPECT_NEAR(walls[0].thickness_m, 0.03, 0.006);
    // The inner face at depth z lies 0.1 z / 0.8 inside the edge: 5 cm in at 0.4 m depth.
    EXPECT_NEAR(PriorHeight(walls, kWallOpening, {0.0, -0.45}), -0.4, 0.06);
    EXPECT_NEAR(PriorHeight(walls, kWallOpening, {0.3, -0.475}), -0.2, 0.06);
    // Beyond the wall's foot, over the floor, the prior says nothing.
    EXPECT_TRUE(std::isnan(PriorHeight(walls, kWallOpening, {0.0, -0.2})));
}

TEST(ThinShellTest, VerticalWallGetsNoPrior) {
    // Its inner face is the opening's edge: the empty surface's bounds already hold it.
    EXPECT_TRUE(
        InnerFaceFromOutside(FrontWallOutside(0.0, 0.03, 0.02, 2), kSensorInFront, kWallOpening)
            .empty());
}

TEST(ThinShellTest, WallSeenFromInsideGetsNoPrior) {
    // A sensor behind the far side sees this wall's inside; its returns there are no outside.
    const Eigen::Vector3d behind(0.0, 2.5, 2.0);
    EXPECT_TRUE(
        InnerFaceFromOutside(FrontWallOutside(0.10, 0.03, 0.02, 3), behind, kWallOpening).empty());
}

TEST(ThinShellTest, PriorRaisesUnseenCellsByTheWallsShareOfThem) {
    const std::vector<WallPrior> walls = {{0, 0.03, 0.002, {{-0.1, 0.0125}, {-0.8, 0.1}}, 100}};
    const volume::Grid grid = volume::MakeGrid(kWallOpening, 0.1);
    volume::EmptySurface empty;
    const auto n = static_cast<std::size_t>(grid.NumCells());
    empty.map.height.assign(n, -0.8);
    empty.map.variance.assign(n, 1e-4);
    empty.map.support.assign(n, 0);
    empty.map.observed.assign(n, 0.0);
    empty.unobserved_sigma_m.assign(n, 0.1);
    const std::size_t seen = n - 1;  // a cell an empty scan saw keeps its fit
    empty.map.support[seen] = 5;
    ApplyWallPriors(walls, kWallOpening, grid, empty);
    // The row along the front edge: the wall's inner face falls from the rim (d = 0) to the
    // floor at d = 0.1 m, a straight line over the 10 cm cell: a mean of -0.4 m.
    const std::size_t front = 5;  // row 0
    EXPECT_NEAR(empty.map.height[front], -0.4, 0.02);
    EXPECT_EQ(empty.map.support[front], 1);
    EXPECT_EQ(empty.unobserved_sigma_m[front], 0.0);
    const std::size_t middle = static_cast<std::size_t>(5 * grid.cols + 5);
    EXPECT_DOUBLE_EQ(empty.map.height[middle], -0.8);
    EXPECT_DOUBLE_EQ(empty.map.height[seen], -0.8);
}

TEST(ThinShellTest, MergeKeepsTheBetterSupportedWallPerEdge) {
    std::vector<WallPrior> walls = {{0, 0.03, 0.002, {}, 50}};
    MergeWalls({{0, 0.04, 0.002, {}, 80}, {2, 0.02, 0.002, {}, 10}}, walls);
    ASSERT_EQ(walls.size(), 2u);
    EXPECT_DOUBLE_EQ(walls[0].thickness_m, 0.04);
    EXPECT_EQ(walls[1].edge, 2);
    MergeWalls({{0, 0.05, 0.002, {}, 20}}, walls);
    EXPECT_DOUBLE_EQ(walls[0].thickness_m, 0.04);
}

}  // namespace
}  // namespace soilvol::model
