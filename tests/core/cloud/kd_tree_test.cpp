#include "core/cloud/kd_tree.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace soilvol::cloud {
namespace {

Cloud RandomCloud(int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    Cloud c;
    for (int i = 0; i < n; ++i) c.push_back({u(rng), u(rng), 0.3f * u(rng)});
    return c;
}

std::vector<float> BruteDistances(const Cloud& c, const Eigen::Vector3f& q) {
    std::vector<float> d;
    for (const auto& p : c) d.push_back((p - q).squaredNorm());
    std::sort(d.begin(), d.end());
    return d;
}

TEST(KdTreeTest, NearestAndRadiusAgreeWithBruteForce) {
    const Cloud cloud = RandomCloud(3000, 1);
    const KdTree tree(cloud);
    const Cloud queries = RandomCloud(50, 2);
    for (const auto& q : queries) {
        const std::vector<float> truth = BruteDistances(cloud, q);
        const auto [i, d2] = tree.Nearest(q);
        ASSERT_GE(i, 0);
        EXPECT_FLOAT_EQ(d2, truth[0]);
        const auto knn = tree.Nearest(q, 7);
        ASSERT_EQ(knn.size(), 7u);
        for (std::size_t k = 0; k < knn.size(); ++k) {
            EXPECT_FLOAT_EQ(knn[k].second, truth[k]);
            EXPECT_FLOAT_EQ((cloud[knn[k].first] - q).squaredNorm(), knn[k].second);
        }
        const auto near = tree.Radius(q, 0.1);
        const auto expected = std::upper_bound(truth.begin(), truth.end(), 0.01f) - truth.begin();
        EXPECT_EQ(static_cast<long>(near.size()), expected);
    }
}

TEST(KdTreeTest, AnyWithinAgreesWithTheNearestDistance) {
    const Cloud cloud = RandomCloud(3000, 3);
    const KdTree tree(cloud);
    const Cloud queries = RandomCloud(200, 4);
    int inside = 0;
    for (const auto& q : queries) {
        const float nearest2 = BruteDistances(cloud, q)[0];
        for (const double r : {0.005, 0.02, 0.05}) {
            const bool expected = nearest2 <= static_cast<float>(r * r);
            EXPECT_EQ(tree.AnyWithin(q, r), expected) << "r " << r;
            inside += expected ? 1 : 0;
        }
        // The bound is the nearest point's distance, up to float rounding.
        const double d = std::sqrt(static_cast<double>(nearest2));
        EXPECT_TRUE(tree.AnyWithin(q, d * (1.0 + 1e-5)));
        EXPECT_FALSE(tree.AnyWithin(q, d * (1.0 - 1e-5)));
    }
    EXPECT_GT(inside, 20);  // both answers were exercised
    EXPECT_LT(inside, 580);
    EXPECT_FALSE(KdTree(Cloud{}).AnyWithin(Eigen::Vector3f::Zero(), 1.0));
}

TEST(KdTreeTest, SmallAndEmptyCloudsAnswerWithWhatTheyHave) {
    const Cloud empty;
    const KdTree none(empty);
    EXPECT_EQ(none.Nearest(Eigen::Vector3f::Zero()).first, -1);
    EXPECT_TRUE(none.Nearest(Eigen::Vector3f::Zero(), 3).empty());
    EXPECT_TRUE(none.Radius(Eigen::Vector3f::Zero(), 1.0).empty());
    const Cloud two = {{0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f}};
    const KdTree tree(two);
    const auto knn = tree.Nearest(Eigen::Vector3f(0.9f, 0.0f, 0.0f), 5);
    ASSERT_EQ(knn.size(), 2u);
    EXPECT_EQ(knn[0].first, 1u);
    EXPECT_EQ(knn[1].first, 0u);
}

}  // namespace
}  // namespace soilvol::cloud
