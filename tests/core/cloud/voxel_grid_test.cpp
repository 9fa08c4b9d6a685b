#include "core/cloud/voxel_grid.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

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

TEST(VoxelGridTest, CentroidsCountTheirPointsAndEachPointKnowsItsCentroid) {
    const Cloud cloud = {
        {0.01f, 0.01f, 0.01f}, {0.51f, 0.01f, 0.01f}, {0.03f, 0.03f, 0.03f}, {0.05f, 0.05f, 0.08f}};
    const VoxelCentroids c = CentroidsOf(cloud, 0.1);
    ASSERT_EQ(c.points.size(), 2u);
    ASSERT_EQ(c.counts.size(), 2u);
    ASSERT_EQ(c.voxel_of.size(), cloud.size());
    EXPECT_EQ(c.voxel_of[0], c.voxel_of[2]);
    EXPECT_EQ(c.voxel_of[0], c.voxel_of[3]);
    EXPECT_NE(c.voxel_of[0], c.voxel_of[1]);
    EXPECT_EQ(c.counts[c.voxel_of[0]], 3.0f);
    EXPECT_EQ(c.counts[c.voxel_of[1]], 1.0f);
    EXPECT_NEAR(c.points[c.voxel_of[0]].z(), 0.04f, 1e-6f);
    EXPECT_TRUE(CentroidsOf({}, 0.1).points.empty());
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

// Every point is found in its own voxel, the voxels partition the points, and a block gathers
// exactly the points whose voxels lie within reach (by brute force), on extents that need
// different key widths per axis and at the grid's edges.
TEST(VoxelGridTest, BlocksGatherExactlyThePointsWithinReach) {
    std::mt19937 rng(3);
    for (const Eigen::Vector3f& extent :
         {Eigen::Vector3f(6.0f, 0.3f, 2.0f), Eigen::Vector3f(0.05f, 9.0f, 0.5f)}) {
        std::uniform_real_distribution<float> unit(0.0f, 1.0f);
        Cloud cloud(3000);
        for (auto& p : cloud) {
            p = Eigen::Vector3f(unit(rng), unit(rng), unit(rng)).cwiseProduct(extent) -
                Eigen::Vector3f(1.0f, 2.0f, 3.0f);
        }
        const VoxelGrid grid(cloud, 0.1);
        std::vector<int> seen(cloud.size(), 0);
        for (std::size_t v = 0; v < grid.NumVoxels(); ++v) {
            const auto [begin, end] = grid.Range(v);
            ASSERT_LT(begin, end);
            for (std::size_t o = begin; o < end; ++o) {
                const uint32_t i = grid.Order()[o];
                ++seen[i];
                EXPECT_EQ(grid.CoordOf(cloud[i]), grid.Coord(v));
                EXPECT_EQ(grid.Find(grid.CoordOf(cloud[i])), static_cast<int64_t>(v));
            }
        }
        EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int n) { return n == 1; }));
        std::vector<uint32_t> gathered;
        for (std::size_t probe = 0; probe < cloud.size(); probe += 97) {
            for (const int reach : {1, 2}) {
                const Eigen::Vector3i c = grid.CoordOf(cloud[probe]);
                grid.GatherBlock(c, reach, gathered);
                std::set<uint32_t> expected;
                for (uint32_t i = 0; i < cloud.size(); ++i) {
                    if (((grid.CoordOf(cloud[i]) - c).array().abs() <= reach).all())
                        expected.insert(i);
                }
                EXPECT_EQ(std::set<uint32_t>(gathered.begin(), gathered.end()), expected);
                EXPECT_EQ(gathered.size(), expected.size());
            }
        }
        // Outside the grid nothing is found.
        EXPECT_EQ(grid.Find(Eigen::Vector3i(-1, 0, 0)), -1);
        EXPECT_EQ(grid.Find(grid.CoordOf(Eigen::Vector3f(100.0f, 0.0f, 0.0f))), -1);
        grid.GatherBlock(grid.CoordOf(Eigen::Vector3f(-50.0f, -50.0f, -50.0f)), 2, gathered);
        EXPECT_TRUE(gathered.empty());
    }
}

TEST(VoxelGridTest, EmptyCloudHasNoVoxels) {
    const Cloud empty;
    const VoxelGrid grid(empty, 0.1);
    EXPECT_EQ(grid.NumVoxels(), 0u);
    EXPECT_EQ(grid.Find(Eigen::Vector3i::Zero()), -1);
    EXPECT_TRUE(VoxelDownsample(empty, 0.1).empty());
}

TEST(VoxelGridTest, NonPositiveSizeReturnsTheCloud) {
    const Cloud cloud = {{1.0f, 2.0f, 3.0f}};
    EXPECT_EQ(VoxelDownsample(cloud, 0.0).size(), 1u);
}

}  // namespace
}  // namespace soilvol::cloud
