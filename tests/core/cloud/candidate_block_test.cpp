#include "core/cloud/candidate_block.hpp"

#include <gtest/gtest.h>

#include <random>

namespace soilvol::cloud {
namespace {

// A block far from the origin (float loses millimetres there without the anchor) and a query
// inside it: the moments and distances agree with a double-precision brute force.
TEST(CandidateBlockTest, MomentsAndDistancesMatchBruteForce) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> offset(-0.15f, 0.15f);
    const Eigen::Vector3f centre(1200.0f, -800.0f, 35.0f);
    Cloud points;
    for (int i = 0; i < 300; ++i) {
        points.push_back(centre + Eigen::Vector3f(offset(rng), offset(rng), 0.2f * offset(rng)));
    }
    CandidateBlock block;
    for (uint32_t i = 0; i < points.size(); i += 2) block.indices().push_back(i);
    block.Load(points, points[0]);
    const Eigen::Vector3f p = points[10];
    constexpr float kRadius = 0.1f;
    const Moments m = block.Within(p, kRadius * kRadius);
    int count = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    for (const uint32_t i : block.index()) {
        const Eigen::Vector3d d = points[i].cast<double>() - p.cast<double>();
        if (d.norm() > static_cast<double>(kRadius)) continue;
        ++count;
        sum += d;
        outer += d * d.transpose();
    }
    ASSERT_GT(count, 10);
    ASSERT_LT(count, 150);
    EXPECT_EQ(m.count, count);
    EXPECT_LT((m.sum - sum).norm(), 1e-5 * count);
    EXPECT_LT((m.outer - outer).norm(), 1e-6 * count);
    std::vector<float> d2;
    block.SquaredDistances(p, d2);
    ASSERT_EQ(d2.size(), block.index().size());
    for (std::size_t j = 0; j < d2.size(); ++j) {
        const double truth =
            (points[block.index()[j]].cast<double>() - p.cast<double>()).squaredNorm();
        EXPECT_NEAR(static_cast<double>(d2[j]), truth, 1e-7);
    }
}

TEST(CandidateBlockTest, EmptyBlockHasNoMoments) {
    CandidateBlock block;
    block.Load(Cloud{}, Eigen::Vector3f::Zero());
    EXPECT_EQ(block.Within(Eigen::Vector3f::Ones(), 1.0f).count, 0);
    std::vector<float> d2{1.0f};
    block.SquaredDistances(Eigen::Vector3f::Ones(), d2);
    EXPECT_TRUE(d2.empty());
}

// A weight counts like that many copies of the point in the sums; the count stays one each.
TEST(CandidateBlockTest, WeightsCountAsCopiesInTheSums) {
    const Cloud points = {
        {0.0f, 0.0f, 0.0f}, {0.1f, 0.0f, 0.0f}, {0.0f, 0.2f, 0.0f}, {5.0f, 0.0f, 0.0f}};
    const std::vector<float> weights = {1.0f, 3.0f, 2.0f, 7.0f};
    CandidateBlock block;
    block.indices() = {0, 1, 2, 3};
    block.Load(points, points[0], weights);
    const Moments m = block.Within(points[0], 0.25f * 0.25f);
    EXPECT_EQ(m.count, 3);
    EXPECT_DOUBLE_EQ(m.weight, 6.0);
    EXPECT_NEAR(m.sum.x(), 0.3, 1e-6);
    EXPECT_NEAR(m.sum.y(), 0.4, 1e-6);
    EXPECT_NEAR(m.outer(0, 0), 0.03, 1e-6);
    EXPECT_NEAR(m.outer(1, 1), 0.08, 1e-6);
    EXPECT_NEAR(m.outer(0, 1), 0.0, 1e-9);
}

}  // namespace
}  // namespace soilvol::cloud
