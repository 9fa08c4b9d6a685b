#include "core/cloud/angular_sampling.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::cloud {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// Returns on a wall 5 m ahead (z forward) of rays on a grid: `row_deg` between rows (elevation
// about x), `step_deg` along them (azimuth about y), over +-15 deg, with 2 cm range noise.
Cloud Wall(double row_deg, double step_deg) {
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0.0, 0.02);
    Cloud out;
    for (double el = -15.0; el <= 15.0; el += row_deg) {
        for (double az = -15.0; az <= 15.0; az += step_deg) {
            const Eigen::Vector3d ray(std::tan(az * kDeg),
                                      std::tan(el * kDeg) / std::cos(az * kDeg), 1.0);
            const double range = 5.0 * ray.norm() + noise(rng);
            out.push_back((range * ray.normalized()).cast<float>());
        }
    }
    return out;
}

TEST(AngularSamplingTest, ASpinningLidarsRingsAreRowsWithTheirGap) {
    const AngularSampling s = MeasureAngularSampling(Wall(1.33, 0.2), Eigen::Vector3d::Zero());
    EXPECT_TRUE(s.rows);
    EXPECT_NEAR(s.along_rad / kDeg, 0.2, 0.02);
    EXPECT_NEAR(s.across_rad / kDeg, 1.33, 0.13);
}

TEST(AngularSamplingTest, APixelGridHasNoRows) {
    const AngularSampling s = MeasureAngularSampling(Wall(0.2, 0.2), Eigen::Vector3d::Zero());
    EXPECT_FALSE(s.rows);
    EXPECT_NEAR(s.along_rad / kDeg, 0.2, 0.02);
    // Rows closer than 3 steps are a grid too: smoothing spans them anyway.
    EXPECT_FALSE(MeasureAngularSampling(Wall(0.5, 0.2), Eigen::Vector3d::Zero()).rows);
}

TEST(AngularSamplingTest, TheSensorsPositionIsWhereDirectionsAreMeasuredFrom) {
    Cloud moved = Wall(1.33, 0.2);
    const Eigen::Vector3f shift(10.0F, -4.0F, 2.0F);
    for (auto& p : moved) p += shift;
    EXPECT_TRUE(MeasureAngularSampling(moved, shift.cast<double>()).rows);
}

TEST(AngularSamplingTest, TooFewReturnsSayNothing) {
    Cloud few = Wall(1.33, 0.2);
    few.resize(40);
    const AngularSampling s = MeasureAngularSampling(few, Eigen::Vector3d::Zero());
    EXPECT_FALSE(s.rows);
    EXPECT_EQ(s.along_rad, 0.0);
    EXPECT_FALSE(MeasureAngularSampling({}, Eigen::Vector3d::Zero()).rows);
}

}  // namespace
}  // namespace soilvol::cloud
