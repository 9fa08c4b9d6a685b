#include "core/common/polygon.hpp"

#include <gtest/gtest.h>

namespace soilvol {
namespace {

Polygon2d Rectangle(double l, double w) {
    return Polygon2d({{-l / 2, -w / 2}, {l / 2, -w / 2}, {l / 2, w / 2}, {-l / 2, w / 2}});
}

TEST(Polygon2dTest, ClockwiseInputIsStoredCounterClockwise) {
    const Polygon2d p({{0, 0}, {0, 1}, {1, 1}, {1, 0}});
    EXPECT_GT(SignedArea(p.Vertices()), 0.0);
    EXPECT_DOUBLE_EQ(p.Area(), 1.0);
}

TEST(Polygon2dTest, ClippedAreasOfAGridSumToTheArea) {
    const Polygon2d p({{0.1, 0.0}, {2.0, 0.3}, {1.7, 1.5}, {0.0, 0.9}});
    double sum = 0.0;
    for (double x = -0.5; x < 2.5; x += 0.07) {
        for (double y = -0.5; y < 2.0; y += 0.07) {
            sum += p.ClippedArea({x, y}, {x + 0.07, y + 0.07});
        }
    }
    EXPECT_NEAR(sum, p.Area(), 1e-9);
}

TEST(Polygon2dTest, ConcaveClipIsExact) {
    // An L-shaped quad: unit square with one corner pushed in.
    const Polygon2d p({{0, 0}, {1, 0}, {0.4, 0.4}, {0, 1}});
    EXPECT_NEAR(p.Area(), 0.4, 1e-12);
    EXPECT_NEAR(p.ClippedArea({0, 0}, {0.5, 0.5}), 7.0 / 30.0, 1e-12);  // by hand
    double sum = 0.0;
    for (int i = 0; i < 10; ++i) {
        for (int j = 0; j < 10; ++j)
            sum += p.ClippedArea({i * 0.1, j * 0.1}, {i * 0.1 + 0.1, j * 0.1 + 0.1});
    }
    EXPECT_NEAR(sum, p.Area(), 1e-12);
}

TEST(Polygon2dTest, ContainsAndDistance) {
    const Polygon2d p = Rectangle(2.0, 1.0);
    EXPECT_TRUE(p.Contains({0.9, 0.4}));
    EXPECT_FALSE(p.Contains({1.1, 0.0}));
    EXPECT_NEAR(p.DistanceToBoundary({0.0, 0.0}), 0.5, 1e-12);
    EXPECT_NEAR(p.DistanceToBoundary({0.8, 0.1}), 0.2, 1e-12);
}

TEST(Polygon2dTest, SelfIntersectingOrderIsNotSimple) {
    EXPECT_TRUE(Rectangle(2, 1).IsSimple());
    const Polygon2d bow({{0, 0}, {1, 1}, {1, 0}, {0, 1}});
    EXPECT_FALSE(bow.IsSimple());
}

TEST(Polygon2dTest, DistanceIntegralMatchesHippedRoofFormula) {
    // int_A d dA over L x W (L >= W) = W^2 L / 4 - W^3 / 12.
    const double l = 2.05, w = 0.54;
    const double expected = w * w * l / 4 - w * w * w / 12;
    EXPECT_NEAR(Rectangle(l, w).DistanceIntegral(800), expected, 1e-4 * expected);
}

}  // namespace
}  // namespace soilvol
