#include "core/common/triangle_bvh.hpp"

#include <gtest/gtest.h>

#include <random>

namespace soilvol {
namespace {

// A grid of n x n unit squares (2 triangles each) in the plane z = height.
void AddPlane(int n, double height, std::vector<Eigen::Vector3d>& v,
              std::vector<Eigen::Vector3i>& t) {
    const int base = static_cast<int>(v.size());
    for (int j = 0; j <= n; ++j) {
        for (int i = 0; i <= n; ++i) v.emplace_back(i, j, height);
    }
    for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
            const int a = base + j * (n + 1) + i;
            t.emplace_back(a, a + 1, a + n + 2);
            t.emplace_back(a, a + n + 2, a + n + 1);
        }
    }
}

TEST(TriangleBvhTest, FirstHitIsTheNearerOfTwoPlanesFromEitherSide) {
    std::vector<Eigen::Vector3d> v;
    std::vector<Eigen::Vector3i> t;
    AddPlane(10, 0.0, v, t);
    AddPlane(10, -2.0, v, t);
    const TriangleBvh bvh(v, t);
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(0.1, 9.9);
    for (int i = 0; i < 100; ++i) {
        const Eigen::Vector3d o(u(rng), u(rng), 1.5);
        const auto down = bvh.IntersectHit(o, Eigen::Vector3d(0, 0, -1), 10.0);
        ASSERT_TRUE(down);
        EXPECT_NEAR(down->distance, 1.5, 1e-9);
        EXPECT_NEAR(std::abs(down->normal.z()), 1.0, 1e-9);
        const auto up = bvh.Intersect(Eigen::Vector3d(o.x(), o.y(), -3.0), Eigen::Vector3d(0, 0, 1),
                                      10.0);  // two-sided
        ASSERT_TRUE(up);
        EXPECT_NEAR(*up, 1.0, 1e-9);
    }
}

TEST(TriangleBvhTest, MissesAndRangesReturnNothing) {
    std::vector<Eigen::Vector3d> v;
    std::vector<Eigen::Vector3i> t;
    AddPlane(4, 0.0, v, t);
    const TriangleBvh bvh(v, t);
    EXPECT_FALSE(bvh.Intersect({5.0, 5.0, 1.0}, {0, 0, -1}, 10.0));  // beside the plane
    EXPECT_FALSE(bvh.Intersect({2.0, 2.0, 1.0}, {0, 0, 1}, 10.0));   // pointing away
    EXPECT_FALSE(bvh.Intersect({2.0, 2.0, 1.0}, {0, 0, -1}, 0.5));   // beyond the range
    EXPECT_TRUE(bvh.Bounds().contains(Eigen::Vector3d(2.0, 2.0, 0.0)));
}

}  // namespace
}  // namespace soilvol
