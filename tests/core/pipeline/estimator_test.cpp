#include "core/pipeline/estimator.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/sim/scene.hpp"

namespace soilvol::pipeline {
namespace {

using sim::ContainerKind;

sim::SensorSpec Sensor(ContainerKind kind, double sigma_m) {
    sim::SensorSpec s = sim::ViewpointFor(kind);
    s.range_noise_sigma_m = sigma_m;
    return s;
}

sim::Scene Scan(ContainerKind kind, double fill_m, double sigma_m, uint64_t scan_seed) {
    sim::SceneSpec spec;
    spec.container = kind;
    spec.sensor = Sensor(kind, sigma_m);
    spec.jitter = {3.0, 0.05};
    spec.soil.fill_height_m = fill_m;
    spec.soil_seed = 11;
    spec.scan_seed = scan_seed;
    return sim::SimulateScene(spec);
}

model::ContainerModel Register(ContainerKind kind, double sigma_m) {
    const sim::Scene empty = Scan(kind, 0.0, sigma_m, 1);
    auto model =
        model::BuildContainerModel(empty.points, empty.opening_corners_scan, model::ModelConfig{});
    EXPECT_TRUE(model.ok()) << model.status();
    return *model;
}

struct Case {
    ContainerKind kind;
    double tolerance_of_struck;  // |error| bound as a share of the struck capacity
};

class EstimatorTest : public ::testing::TestWithParam<Case> {};

// A precise sensor (1 cm) and a moved container: the estimate must track the exact volume at
// every fill, the empty container included, within the stated share of the struck capacity.
TEST_P(EstimatorTest, FillsAreMeasuredWithinToleranceOfTheTruth) {
    const Case c = GetParam();
    const model::ContainerModel model = Register(c.kind, 0.01);
    const sim::ContainerGeometry geometry = sim::MakeContainer(c.kind);
    EXPECT_NEAR(model.struck_capacity_m3, geometry.struck_capacity_m3,
                c.tolerance_of_struck * geometry.struck_capacity_m3);
    uint64_t seed = 2;
    for (const double share : {0.0, 0.3, 0.6, 0.9}) {
        const sim::Scene scene = Scan(c.kind, share * geometry.depth_m, 0.01, seed++);
        const auto estimate = EstimateVolume(model, scene.points, EstimateConfig{});
        ASSERT_TRUE(estimate.ok()) << estimate.status();
        EXPECT_NEAR(estimate->volume_m3, scene.true_volume_m3,
                    c.tolerance_of_struck * geometry.struck_capacity_m3)
            << "fill share " << share;
        EXPECT_TRUE(estimate->alignment.converged);
        EXPECT_GT(estimate->uncertainty_m3, 0.0);
    }
}

INSTANTIATE_TEST_SUITE_P(Containers, EstimatorTest,
                         ::testing::Values(Case{ContainerKind::kPaperBucket, 0.01},
                                           // Reads 1.0-1.3% low at 60-90% fill here; the
                                           // issue's target (1.5% max) is what this guards.
                                           Case{ContainerKind::kTruckBed, 0.015},
                                           // Its curved back is the wall nearest the sensor:
                                           // the top of its inside is never seen empty and is
                                           // filled flat, 20 cm too deep (BENCHMARK.md).
                                           Case{ContainerKind::kExcavatorBucket, 0.08}));

TEST(EstimatorTest, PaperSensorEmptyBucketReadsBelowOnePercentOfStruck) {
    const model::ContainerModel model = Register(ContainerKind::kPaperBucket, 0.04);
    double sum = 0.0;
    for (uint64_t seed = 20; seed < 24; ++seed) {
        const sim::Scene scene = Scan(ContainerKind::kPaperBucket, 0.0, 0.04, seed);
        const auto estimate = EstimateVolume(model, scene.points, EstimateConfig{});
        ASSERT_TRUE(estimate.ok()) << estimate.status();
        sum += estimate->volume_m3;
    }
    EXPECT_LT(sum / 4, 0.01 * 0.6642);  // the paper reports 17.6 L here
}

TEST(EstimatorTest, PaperMethodRunsOnTheSameModel) {
    const model::ContainerModel model = Register(ContainerKind::kPaperBucket, 0.01);
    const sim::Scene scene = Scan(ContainerKind::kPaperBucket, 0.3, 0.01, 5);
    EstimateConfig config;
    config.method = volume::Method::kPaper;
    const auto estimate = EstimateVolume(model, scene.points, config);
    ASSERT_TRUE(estimate.ok()) << estimate.status();
    EXPECT_NEAR(estimate->volume_m3, scene.true_volume_m3, 0.15 * scene.true_volume_m3);
}

TEST(EstimatorTest, ScanOfSomethingElseIsRefusedByTheAlignmentGate) {
    const model::ContainerModel model = Register(ContainerKind::kPaperBucket, 0.01);
    Cloud wall;
    for (double x = -1.0; x <= 1.0; x += 0.02) {
        for (double y = -1.0; y <= 1.0; y += 0.02) wall.emplace_back(x, y, 6.0);
    }
    const auto estimate = EstimateVolume(model, wall, EstimateConfig{});
    ASSERT_FALSE(estimate.ok());
    EXPECT_EQ(estimate.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(estimate.status().message().find("alignment rejected"), std::string::npos);
}

TEST(EstimatorTest, EmptyScanIsInvalidArgument) {
    const model::ContainerModel model = Register(ContainerKind::kPaperBucket, 0.01);
    const auto estimate = EstimateVolume(model, Cloud{}, EstimateConfig{});
    ASSERT_FALSE(estimate.ok());
    EXPECT_EQ(estimate.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(EstimatorTest, InitialPoseFromKinematicsIsUsed) {
    const model::ContainerModel model = Register(ContainerKind::kPaperBucket, 0.01);
    // The container moved 25 cm: beyond ICP's reach from the registered pose, fine from a
    // kinematic guess within a few centimetres.
    sim::SceneSpec spec;
    spec.sensor = Sensor(ContainerKind::kPaperBucket, 0.01);
    spec.soil.fill_height_m = 0.3;
    spec.scan_seed = 9;
    sim::Scene scene = sim::SimulateScene(spec);
    Pose shift = Pose::Identity();
    shift.translation() = Eigen::Vector3d(0.25, 0.0, 0.0);
    for (auto& p : scene.points) p = (shift * p.cast<double>()).cast<float>();
    EstimateConfig config;
    Pose guess = shift * scene.T_scan_container;
    guess.translation() += Eigen::Vector3d(0.02, -0.02, 0.01);
    config.initial_T_scan_container = guess;
    const auto estimate = EstimateVolume(model, scene.points, config);
    ASSERT_TRUE(estimate.ok()) << estimate.status();
    EXPECT_NEAR(estimate->volume_m3, scene.true_volume_m3, 0.01 * 0.6642);
}

}  // namespace
}  // namespace soilvol::pipeline
