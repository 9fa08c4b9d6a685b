#include "core/model/container_model.hpp"

#include <gtest/gtest.h>

#include "core/sim/scene.hpp"
#include "core/sim/tof_sensor.hpp"

namespace soilvol::model {
namespace {

sim::Scene EmptyScan(sim::ContainerKind kind, double sigma_m) {
    sim::SceneSpec spec;
    spec.container = kind;
    spec.sensor.range_noise_sigma_m = sigma_m;
    spec.sensor.elevation_deg = 55.0;
    spec.sensor.azimuth_deg = 60.0;
    spec.jitter = {3.0, 0.05};
    spec.scan_seed = 3;
    return sim::SimulateScene(spec);
}

TEST(ContainerModelTest, PaperBucketCapacitiesMatchTheGeometry) {
    const sim::Scene scan = EmptyScan(sim::ContainerKind::kPaperBucket, 0.01);
    const auto model = BuildContainerModel(scan.points, scan.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    EXPECT_NEAR(model->opening.area_m2, 2.05 * 0.54, 1e-6);
    // Struck within 1% of 0.6642 m^3; heaped = struck + exact heap of the opening.
    EXPECT_NEAR(model->struck_capacity_m3, scan.struck_capacity_m3, 0.01 * scan.struck_capacity_m3);
    const double heap_sae = 0.54 * 0.54 * 2.05 / 4 - 0.54 * 0.54 * 0.54 / 12;
    EXPECT_NEAR(model->heaped_capacity_sae_m3 - model->struck_capacity_m3, heap_sae,
                1e-3 * heap_sae);
    EXPECT_NEAR(model->heaped_capacity_iso_m3 - model->struck_capacity_m3, heap_sae / 2,
                1e-3 * heap_sae);
    EXPECT_NEAR(model->depth_m, 0.6, 0.03);
    // The frame: z along the opening normal, out of the container.
    const Eigen::Vector3d z_true = scan.T_scan_container.linear().col(2);
    EXPECT_GT(model->opening.T_scan_container.linear().col(2).dot(z_true), 0.9999);
    EXPECT_TRUE(model->opening.T_scan_container.translation().isApprox(
        scan.T_scan_container.translation(), 1e-6));
    EXPECT_GT(model->alignment_points.size(), 100u);
    EXPECT_EQ(model->alignment_points.size(), model->alignment_normals.size());
}

TEST(ContainerModelTest, InsideAndOutsideSplitFollowsTheOpening) {
    const sim::Scene scan = EmptyScan(sim::ContainerKind::kPaperBucket, 0.0);
    const auto model = BuildContainerModel(scan.points, scan.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    for (const auto& p : model->inside) {
        EXPECT_TRUE(model->opening.polygon.Contains(p.head<2>().cast<double>()));
        EXPECT_LE(p.z(), 0.05f);
    }
    // The alignment set keeps out of the opening's column below the rim.
    for (const auto& p : model->alignment_points) {
        const Eigen::Vector2d xy = p.head<2>().cast<double>();
        const bool in_column = model->opening.polygon.Contains(xy) &&
                               model->opening.polygon.DistanceToBoundary(xy) > 0.15;
        EXPECT_FALSE(in_column && p.z() < -0.15f) << p.transpose();
    }
}

TEST(ContainerModelTest, CornersAwayFromTheContainerAreRefused) {
    const sim::Scene scan = EmptyScan(sim::ContainerKind::kPaperBucket, 0.01);
    Corners far = scan.opening_corners_scan;
    for (auto& c : far) c += Eigen::Vector3d(0.0, 0.0, 20.0);
    const auto model = BuildContainerModel(scan.points, far, ModelConfig{});
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(ContainerModelTest, TooFewInsidePointsIsFailedPrecondition) {
    const sim::Scene scan = EmptyScan(sim::ContainerKind::kPaperBucket, 0.01);
    ModelConfig config;
    config.min_inside_points = 1000000;
    const auto model = BuildContainerModel(scan.points, scan.opening_corners_scan, config);
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(model.status().message().find("inside the opening"), std::string::npos);
}

TEST(ContainerModelTest, OnlyTheInsideVisibleIsFailedPrecondition) {
    const sim::Scene scan = EmptyScan(sim::ContainerKind::kPaperBucket, 0.01);
    const auto opening = MakeOpening(scan.opening_corners_scan, scan.points, OpeningConfig{});
    ASSERT_TRUE(opening.ok());
    Cloud inside_only;
    for (const auto& p : scan.points) {
        const Eigen::Vector3f q =
            (opening->T_scan_container.inverse() * p.cast<double>()).cast<float>();
        if (opening->polygon.Contains(q.head<2>().cast<double>()) && q.z() < -0.1f)
            inside_only.push_back(p);
    }
    const auto model = BuildContainerModel(inside_only, scan.opening_corners_scan, ModelConfig{});
    ASSERT_FALSE(model.ok());
    EXPECT_EQ(model.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(model.status().message().find("outside"), std::string::npos);
}

// A spinning lidar's rings 1.33 deg apart, 5 m from a truck bed, are 12 cm apart there: each
// 8 cm neighbourhood would be one ring. The model smooths over 1.25 gaps; a ray grid of 0.5 deg
// (no rows) keeps the configured radius.
TEST(ContainerModelTest, ALidarsRingsWidenTheSmoothingAGridDoesNot) {
    sim::SceneSpec spec;
    spec.container = sim::ContainerKind::kTruckBed;
    spec.sensor = sim::ViewpointFor(sim::ContainerKind::kTruckBed);
    spec.scan_seed = 5;
    const sim::Scene grid = sim::SimulateScene(spec);
    spec.sensor = sim::TypicalSpinningLidar(spec.sensor);
    const sim::Scene rings = sim::SimulateScene(spec);
    const ModelConfig config;
    const auto from_grid = BuildContainerModel(grid.points, grid.opening_corners_scan, config);
    const auto from_rings = BuildContainerModel(rings.points, rings.opening_corners_scan, config);
    ASSERT_TRUE(from_grid.ok()) << from_grid.status();
    ASSERT_TRUE(from_rings.ok()) << from_rings.status();
    EXPECT_NEAR(
        from_grid->smoothing_radius_m,
        std::max(config.smoothing_radius_m, config.smoothing_sigmas * from_grid->noise_sigma_m),
        1e-12);
    // 1.25 x 1.33 deg at the scan's median range (5-7 m): 14-20 cm.
    EXPECT_GT(from_rings->smoothing_radius_m, 0.14);
    EXPECT_LT(from_rings->smoothing_radius_m, 0.21);
}

}  // namespace
}  // namespace soilvol::model
