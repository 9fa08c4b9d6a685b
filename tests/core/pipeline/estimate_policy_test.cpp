#include "core/pipeline/estimate_policy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace soilvol::pipeline {
namespace {

/// A 2 x 1 m opening whose registration scan held `points` points over it.
model::ContainerModel Model(std::size_t points) {
    model::ContainerModel model;
    model.opening.polygon = Polygon2d({{-1.0, -0.5}, {1.0, -0.5}, {1.0, 0.5}, {-1.0, 0.5}});
    model.opening.area_m2 = 2.0;
    model.inside.resize(points, Eigen::Vector3f::Zero());
    return model;
}

bool Names(const absl::Status& status, const std::string& field) {
    return status.message().substr(0, field.size() + 1) == field + ":";
}

TEST(EstimatePolicy, DefaultsPassThrough) {
    EstimateRequest request;
    request.max_range_m = 12.0;
    const absl::StatusOr<EstimateConfig> config = ConfigureEstimate(request, Model(20000));
    ASSERT_TRUE(config.ok()) << config.status();
    EXPECT_EQ(config->method, volume::Method::kHeightmap);
    EXPECT_FALSE(config->initial_T_scan_container.has_value());
    EXPECT_DOUBLE_EQ(config->preprocess.max_range_m, 12.0);
}

TEST(EstimatePolicy, CellSizeOutOfRangeOrTooManyCellsIsRefused) {
    EstimateRequest request;
    for (const double cell : {0.0, -0.1, 0.001, 3.0, std::nan("")}) {
        request.grid_cell_m = cell;
        const absl::Status status = ConfigureEstimate(request, Model(20000)).status();
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << cell;
        EXPECT_TRUE(Names(status, "grid_cell_m")) << status;
    }
    // 2 m^2 in 5 mm cells is 80,000 cells: within the cap. A 30 x 13 m opening is not.
    request.grid_cell_m = 0.005;
    EXPECT_TRUE(ConfigureEstimate(request, Model(20000)).ok());
    model::ContainerModel large = Model(20000);
    large.opening.polygon = Polygon2d({{-15.0, -6.5}, {15.0, -6.5}, {15.0, 6.5}, {-15.0, 6.5}});
    large.opening.area_m2 = 390.0;
    const absl::Status status = ConfigureEstimate(request, large).status();
    EXPECT_TRUE(absl::IsInvalidArgument(status));
    EXPECT_NE(status.message().find("cells over the opening"), std::string::npos) << status;
}

TEST(EstimatePolicy, PaperCellsNeedPointsInEachCell) {
    EstimateRequest request;
    request.method = volume::Method::kPaper;
    request.grid_cell_m = 0.02;  // 2000 points over 2 m^2: 0.4 points per 2 cm cell
    const absl::Status status = ConfigureEstimate(request, Model(2000)).status();
    EXPECT_TRUE(absl::IsFailedPrecondition(status));
    EXPECT_NE(status.message().find("use cells of at least"), std::string::npos) << status;
    request.grid_cell_m = 0.10;  // 10 points per cell
    EXPECT_TRUE(ConfigureEstimate(request, Model(2000)).ok());
    request.method = volume::Method::kHeightmap;  // interpolates: any density
    request.grid_cell_m = 0.02;
    EXPECT_TRUE(ConfigureEstimate(request, Model(2000)).ok());
}

TEST(EstimatePolicy, DensityMustBePhysical) {
    EstimateRequest request;
    for (const double density : {0.0, -1600.0, 1e6, std::nan("")}) {
        request.material_density_kg_m3 = density;
        const absl::Status status = ConfigureEstimate(request, Model(20000)).status();
        EXPECT_TRUE(Names(status, "material_density_kg_m3")) << density;
    }
    request.material_density_kg_m3 = 1600.0;
    EXPECT_TRUE(ConfigureEstimate(request, Model(20000)).ok());
}

TEST(EstimatePolicy, KinematicPoseAndItsAccuracy) {
    EstimateRequest request;
    Pose pose = Pose::Identity();
    pose.translation() = Eigen::Vector3d(0.4, 0.0, 2.0);
    request.kinematic_pose = pose;
    absl::StatusOr<EstimateConfig> config = ConfigureEstimate(request, Model(20000));
    ASSERT_TRUE(config.ok());
    ASSERT_TRUE(config->initial_T_scan_container.has_value());
    EXPECT_TRUE(config->initial_T_scan_container->isApprox(pose));
    EXPECT_DOUBLE_EQ(config->kinematic_position_sigma_m,
                     EstimateConfig{}.kinematic_position_sigma_m);
    request.kinematic_position_sigma_m = 0.1;
    request.kinematic_orientation_sigma_deg = 5.0;
    config = ConfigureEstimate(request, Model(20000));
    ASSERT_TRUE(config.ok());
    EXPECT_DOUBLE_EQ(config->kinematic_position_sigma_m, 0.1);
    EXPECT_DOUBLE_EQ(config->kinematic_orientation_sigma_deg, 5.0);
    request.kinematic_position_sigma_m = 2.0;
    EXPECT_TRUE(Names(ConfigureEstimate(request, Model(20000)).status(),
                      "container_pose.position_sigma_m"));
    request.kinematic_position_sigma_m = 0.1;
    request.kinematic_orientation_sigma_deg = -1.0;
    EXPECT_TRUE(Names(ConfigureEstimate(request, Model(20000)).status(),
                      "container_pose.orientation_sigma_deg"));
}

TEST(EstimatePolicy, ScansComeFromTheRegisteredSensor) {
    EXPECT_TRUE(CheckSameSensor("b", ScanKind::kCloud, "", ScanKind::kCloud, "").ok());
    EXPECT_TRUE(CheckSameSensor("b", ScanKind::kStereo, "rig", ScanKind::kStereo, "").ok());
    EXPECT_TRUE(CheckSameSensor("b", ScanKind::kStereo, "rig", ScanKind::kStereo, "rig").ok());
    const absl::Status cloud = CheckSameSensor("b", ScanKind::kStereo, "rig", ScanKind::kCloud, "");
    EXPECT_TRUE(absl::IsFailedPrecondition(cloud));
    EXPECT_TRUE(Names(cloud, "scan.cloud"));
    EXPECT_TRUE(
        Names(CheckSameSensor("b", ScanKind::kCloud, "", ScanKind::kStereo, ""), "scan.stereo"));
    EXPECT_TRUE(Names(CheckSameSensor("b", ScanKind::kStereo, "rig", ScanKind::kStereo, "other"),
                      "scan.stereo.calibration_id"));
}

}  // namespace
}  // namespace soilvol::pipeline
