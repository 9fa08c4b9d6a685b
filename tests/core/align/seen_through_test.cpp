#include "core/align/seen_through.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::align {
namespace {

// A wall 3 m in front of the sensor (the origin), returns on a 0.25 deg ray grid with 1 cm
// range noise.
Cloud Wall(double range_m) {
    std::mt19937 rng(3);
    std::normal_distribution<double> noise(0.0, 0.01);
    Cloud wall;
    const double step = 0.25 * 3.14159265358979 / 180.0;
    for (double a = -0.3; a <= 0.3; a += step) {
        for (double b = -0.3; b <= 0.3; b += step) {
            const Eigen::Vector3d ray = Eigen::Vector3d(std::tan(a), std::tan(b), 1.0).normalized();
            const double r = range_m / ray.z() + noise(rng);
            wall.push_back((r * ray).cast<float>());
        }
    }
    return wall;
}

Cloud Patch(double z) {
    Cloud patch;
    for (double x = -0.3; x <= 0.3; x += 0.03) {
        for (double y = -0.3; y <= 0.3; y += 0.03) patch.emplace_back(x, y, z);
    }
    return patch;
}

TEST(SeenThroughTest, OnTheSurfaceOrBehindItIsNoEvidenceInFrontOfItIs) {
    const Cloud scan = Wall(3.0);
    const SeenThrough on = SeenThroughShare(Patch(3.0), scan, 0.01);
    EXPECT_GT(on.tested, 300u);
    EXPECT_EQ(on.through, 0u);
    // Behind the wall: occluded, the rays ended before reaching it.
    EXPECT_EQ(SeenThroughShare(Patch(3.5), scan, 0.01).through, 0u);
    // Half a metre in front of it: the rays passed through where the model says a surface is.
    const SeenThrough floating = SeenThroughShare(Patch(2.5), scan, 0.01);
    EXPECT_EQ(floating.through, floating.tested);
    EXPECT_GT(floating.Share(), 0.99);
    // Within the margin (4 noise sigmas, at least 5 cm) of the surface: noise, not evidence.
    EXPECT_EQ(SeenThroughShare(Patch(2.97), scan, 0.01).through, 0u);
}

TEST(SeenThroughTest, PointsOutsideTheFieldOfViewAreNotTested) {
    Cloud aside;
    for (double y = -0.3; y <= 0.3; y += 0.03) aside.emplace_back(5.0, y, 3.0);
    const SeenThrough result = SeenThroughShare(aside, Wall(3.0), 0.01);
    EXPECT_EQ(result.tested, 0u);
    EXPECT_EQ(result.Share(), 0.0);
    EXPECT_EQ(SeenThroughShare(Patch(2.5), Cloud{}, 0.01).tested, 0u);
}

}  // namespace
}  // namespace soilvol::align
