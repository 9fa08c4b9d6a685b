#include "core/cloud/sensor_frame.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::cloud {
namespace {

// A sensor 5 m up a gantry, tilted 30 deg about x and turned 40 deg about z.
Pose Gantry() {
    Pose pose = Pose::Identity();
    pose.linear() = (Eigen::AngleAxisd(40.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                     Eigen::AngleAxisd(30.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()))
                        .matrix();
    pose.translation() = Eigen::Vector3d(3.0, -2.0, 5.0);
    return pose;
}

Cloud SensorFrameCloud() {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> along(-1.5f, 1.5f);
    std::uniform_real_distribution<float> ahead(1.0f, 6.0f);
    Cloud points(2000);
    for (Eigen::Vector3f& p : points) p = {along(rng), along(rng), ahead(rng)};
    return points;
}

TEST(SensorFrameTest, SiteFramePointsReturnToTheSensorFrame) {
    const Pose sensor = Gantry();
    const Cloud original = SensorFrameCloud();
    Cloud site(original.size());
    for (std::size_t i = 0; i < site.size(); ++i) {
        site[i] = (sensor * original[i].cast<double>()).cast<float>();
    }
    const Cloud back = InSensorFrame(site, sensor);
    ASSERT_EQ(back.size(), original.size());
    for (std::size_t i = 0; i < back.size(); ++i) {
        // Two roundings to float of coordinates up to ~9 m: a few 1e-7 of their size.
        EXPECT_LT((back[i] - original[i]).norm(), 2e-6f) << i;
        // Ranges from the sensor are what the sensor measured.
        EXPECT_NEAR(back[i].norm(), original[i].norm(), 2e-6f) << i;
    }
}

TEST(SensorFrameTest, TheIdentityLeavesThePointsUntouched) {
    const Cloud original = SensorFrameCloud();
    EXPECT_EQ(InSensorFrame(original, Pose::Identity()), original);
}

}  // namespace
}  // namespace soilvol::cloud
