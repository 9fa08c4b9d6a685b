#include "core/cloud/ray_weights.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::cloud {
namespace {

// A patch of a plane through `centre` spanned by unit u, v, with noise along the rays from
// `sensor` (the way a range sensor errs).
Cloud Patch(const Eigen::Vector3d& centre, const Eigen::Vector3d& u, const Eigen::Vector3d& v,
            const Eigen::Vector3d& sensor, double sigma, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> s(-0.4, 0.4);
    std::normal_distribution<double> noise(0.0, sigma);
    Cloud cloud;
    for (int i = 0; i < 3000; ++i) {
        const Eigen::Vector3d p = centre + s(rng) * u + s(rng) * v;
        cloud.push_back((p + noise(rng) * (p - sensor).normalized()).cast<float>());
    }
    return cloud;
}

double MedianWeight(std::vector<float> w) {
    std::nth_element(w.begin(), w.begin() + static_cast<long>(w.size() / 2), w.end());
    return static_cast<double>(w[w.size() / 2]);
}

const Eigen::Vector3d kX = Eigen::Vector3d::UnitX(), kY = Eigen::Vector3d::UnitY(),
                      kZ = Eigen::Vector3d::UnitZ();

TEST(RayWeightsTest, FloorSeenFromFortyFiveDegreesWeighsTwo) {
    // v = n_z^2 / (r.n)^2 = 1 / sin^2(45 deg) = 2.
    const Eigen::Vector3d sensor(0.0, -2.0, 2.0);
    const Cloud floor = Patch(Eigen::Vector3d::Zero(), kX, kY, sensor, 0.02, 1);
    const auto w = RayWeights(floor, sensor, 0.02, RayWeightConfig{});
    ASSERT_EQ(w.size(), floor.size());
    // The rays' angle varies over the patch (about 40-50 deg).
    EXPECT_NEAR(MedianWeight(w), 2.0, 0.3);
}

TEST(RayWeightsTest, VerticalWallFacingTheSensorTellsNoHeight) {
    const Eigen::Vector3d sensor(0.0, -2.0, 2.0);
    const Cloud wall = Patch({0.0, 0.5, 0.0}, kX, kZ, sensor, 0.03, 2);
    const auto w = RayWeights(wall, sensor, 0.03, RayWeightConfig{});
    EXPECT_LT(MedianWeight(w), 0.02);
}

TEST(RayWeightsTest, SteeperWallsWeighLessAndNoWeightIsNegativeOrAboveTheCap) {
    const Eigen::Vector3d sensor(0.0, -2.5, 2.0);
    double previous = 1e9;
    for (const double deg : {20.0, 45.0, 70.0, 85.0}) {
        const double a = deg * 3.14159265358979 / 180.0;
        // A wall facing the sensor, rising at `deg` towards +y.
        const Eigen::Vector3d up(0.0, std::cos(a), std::sin(a));
        const auto w = RayWeights(Patch(Eigen::Vector3d::Zero(), kX, up, sensor, 0.02, 3), sensor,
                                  0.02, RayWeightConfig{});
        const double median = MedianWeight(w);
        EXPECT_LT(median, previous) << deg;
        previous = median;
        for (const float x : w) {
            EXPECT_GE(x, 0.0f);
            EXPECT_LE(x, 4.0f);
        }
    }
}

TEST(RayWeightsTest, IsolatedPointsAndEmptyCloudsGetNoWeight) {
    EXPECT_TRUE(RayWeights({}, Eigen::Vector3d::Zero(), 0.02, RayWeightConfig{}).empty());
    const Cloud lone = {Eigen::Vector3f(0, 0, 0), Eigen::Vector3f(5, 5, 5)};
    const auto w = RayWeights(lone, Eigen::Vector3d(0, 0, 3), 0.02, RayWeightConfig{});
    ASSERT_EQ(w.size(), 2u);
    EXPECT_EQ(w[0], 0.0f);
    EXPECT_EQ(w[1], 0.0f);
}

}  // namespace
}  // namespace soilvol::cloud
