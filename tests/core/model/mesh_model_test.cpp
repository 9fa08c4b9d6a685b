#include "core/model/mesh_model.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/model/opening.hpp"
#include "core/pipeline/registration.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::model {
namespace {

struct Case {
    sim::ContainerGeometry geometry;
    sim::Scene empty;  // an empty scan: its pose is where the sensor sees the container
};

Case SlopedBucket(double noise_m) {
    sim::ContainerShape shape;
    shape.family = sim::ContainerFamily::kSlopedSymmetric;
    shape.length_m = 1.6, shape.width_m = 0.9, shape.depth_m = 0.7;
    shape.front_wall_deg = shape.back_wall_deg = 74.0;
    sim::SceneSpec spec;
    spec.shape = shape;
    spec.sensor = sim::ViewpointFor(shape, 3);
    spec.sensor.range_noise_sigma_m = noise_m;
    return {sim::MakeContainer(shape), sim::SimulateScene(spec)};
}

TriangleMesh MeshOf(const sim::ContainerGeometry& g) { return {g.vertices, g.triangles}; }

TEST(MeshModelTest, MeshGivesTheExactCapacityEveryCellObserved) {
    const Case c = SlopedBucket(0.02);
    const auto model = BuildMeshModel(MeshOf(c.geometry), c.geometry.opening_corners,
                                      c.empty.T_scan_container, 0.02, {});
    ASSERT_TRUE(model.ok()) << model.status();
    // The 4 x 4 samples a cell integrate the sloped walls to well within 0.3% of the truth.
    EXPECT_NEAR(model->struck_capacity_m3, c.geometry.struck_capacity_m3,
                0.003 * c.geometry.struck_capacity_m3);
    EXPECT_DOUBLE_EQ(model->observed_share, 1.0);
    EXPECT_LT(model->struck_capacity_sigma_m3, 0.001 * c.geometry.struck_capacity_m3);
    EXPECT_TRUE(model->unseen.empty());
    EXPECT_NEAR(model->noise_sigma_m, 0.02, 1e-12);
    EXPECT_GT(model->alignment_points.size(), 100u);
    EXPECT_TRUE(pipeline::CapacityWarnings(*model, 0.01).empty());
}

TEST(MeshModelTest, MeshEmptySurfaceIsTheInnerSurface) {
    const Case c = SlopedBucket(0.0);
    const auto model = BuildMeshModel(MeshOf(c.geometry), c.geometry.opening_corners,
                                      c.empty.T_scan_container, 0.01, {});
    ASSERT_TRUE(model.ok()) << model.status();
    const volume::Grid grid = volume::MakeGrid(model->opening.polygon, 0.05);
    const volume::EmptySurface e = MeshEmptySurface(model->mesh, model->opening.polygon, grid);
    // Cells away from the sloped walls hold the flat floor exactly.
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        if (grid.weight[k] <= 0.0 ||
            model->opening.polygon.DistanceToBoundary(grid.anchor[k]) < 0.3)
            continue;
        EXPECT_NEAR(e.map.height[k],
                    c.geometry.InnerSurfaceZ(grid.anchor[k].x(), grid.anchor[k].y()), 1e-6);
    }
}

TEST(MeshModelTest, ImpossibleInputsAreInvalidArgumentNamingTheField) {
    const Case c = SlopedBucket(0.02);
    const TriangleMesh mesh = MeshOf(c.geometry);
    const auto noise =
        BuildMeshModel(mesh, c.geometry.opening_corners, c.empty.T_scan_container, 0.0, {});
    ASSERT_EQ(noise.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(noise.status().message().find("range_noise_m"), std::string::npos);
    // The container 3 m above the sensor: the sensor is below its opening plane.
    Pose above = Pose::Identity();
    above.translation() = Eigen::Vector3d(0.0, 0.0, 3.0);
    const auto below = BuildMeshModel(mesh, c.geometry.opening_corners, above, 0.02, {});
    ASSERT_EQ(below.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(below.status().message().find("container_pose"), std::string::npos);
    Corners collinear = c.geometry.opening_corners;
    collinear[2] = collinear[1] + (collinear[1] - collinear[0]);
    const auto corners = BuildMeshModel(mesh, collinear, c.empty.T_scan_container, 0.02, {});
    EXPECT_EQ(corners.status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(MeshModelTest, AttachedMeshGivesAScannedModelItsExactInside) {
    const Case c = SlopedBucket(0.03);
    auto model = BuildContainerModel(c.empty.points, c.empty.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    // One view leaves the near wall's inside unseen: the capacity is unsure.
    EXPECT_GT(model->struck_capacity_sigma_m3, 0.0);
    ASSERT_TRUE(
        AttachMesh(MeshOf(c.geometry), c.geometry.opening_corners, ModelConfig{}, *model).ok());
    EXPECT_NEAR(model->struck_capacity_m3, c.geometry.struck_capacity_m3,
                0.003 * c.geometry.struck_capacity_m3);
    EXPECT_DOUBLE_EQ(model->observed_share, 1.0);
    EXPECT_FALSE(model->alignment_points.empty());  // the scan's, kept
}

TEST(MeshModelTest, AttachingAnotherContainersMeshIsRefused) {
    const Case c = SlopedBucket(0.02);
    auto model = BuildContainerModel(c.empty.points, c.empty.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    TriangleMesh bigger = MeshOf(c.geometry);
    Corners corners = c.geometry.opening_corners;
    for (auto& v : bigger.vertices) v *= 1.2;
    for (auto& v : corners) v *= 1.2;
    const absl::Status status = AttachMesh(bigger, corners, ModelConfig{}, *model);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find("mesh.opening"), std::string::npos);
}

TEST(MeshModelTest, OneViewOfALeaningWallWarnsNamingTheSideToScanFrom) {
    const Case c = SlopedBucket(0.03);
    const auto model =
        BuildContainerModel(c.empty.points, c.empty.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    ASSERT_FALSE(model->unseen.empty());
    const auto warnings = pipeline::CapacityWarnings(*model, 1e-4);
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("along the side from corner"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("beyond the opposite side"), std::string::npos);
    EXPECT_TRUE(pipeline::CapacityWarnings(*model, 0.5).empty());
}

}  // namespace
}  // namespace soilvol::model
