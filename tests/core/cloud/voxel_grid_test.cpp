#include "core/cloud/voxel_grid.hpp"

#include <gtest/gtest.h>

namespace soilvol::cloud {
namespace {

TEST(VoxelGridTest, DownsampleAveragesEachVoxel) {
    const Cloud cloud = {{0.01f, 0.01f, 0.01f}, {0.03f, 0.03f, 0.03f}, {0.51f, 0.01f, 0.01f}};
    Cloud out = VoxelDownsample(cloud, 0.1);
    ASSERT_EQ(out.size(), 2u);
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.x() < b.x(); });
    EXPECT_NEAR(out[0].x(), 0.02f, 1e-6f);
    EXPECT_NEAR(out[1].x(), 0.51f, 1e-6f);
}

TEST(VoxelGridTest, FindsOccupiedNeighbours) {
    const Cloud cloud = {{0.0f, 0.0f, 0.0f}, {0.15f, 0.0f, 0.0f}, {-3.0f, 2.0f, 1.0f}};
    const VoxelGrid grid(cloud, 0.1);
    EXPECT_EQ(grid.NumVoxels(), 3u);
    const Eigen::Vector3i c = grid.CoordOf(cloud[0]);
    EXPECT_GE(grid.Find(c), 0);
    EXPECT_GE(grid.Find(c + Eigen::Vector3i(1, 0, 0)), 0);
    EXPECT_LT(grid.Find(c + Eigen::Vector3i(0, 1, 0)), 0);
}

TEST(VoxelGridTest, NonPositiveSizeReturnsTheCloud) {
    const Cloud cloud = {{1.0f, 2.0f, 3.0f}};
    EXPECT_EQ(VoxelDownsample(cloud, 0.0).size(), 1u);
}

}  // namespace
}  // namespace soilvol::cloud
