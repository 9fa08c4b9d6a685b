#include "client/demo_scene.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "core/io/mesh_codec.hpp"
#include "proto/convert/proto_convert.hpp"

namespace soilvol::client {
namespace {

TEST(DemoRigParameters, CarryTheWholeRig) {
    const DemoSetup setup = MakeDemoSetup(sim::ContainerKind::kPaperBucket, DemoSensor::kStereo, 1);
    const v1::StereoParameters p = DemoRigParameters(setup);
    EXPECT_EQ(p.image_width(), 640);
    EXPECT_EQ(p.image_height(), 480);
    EXPECT_EQ(p.rotation_size(), 9);
    ASSERT_EQ(p.translation_m_size(), 3);
    EXPECT_NEAR(p.translation_m(0), -0.10, 1e-3);  // right camera 10 cm to the right
    EXPECT_GT(p.left().fx(), 0.0);
    EXPECT_EQ(p.left().distortion_size(), 5);
    EXPECT_GE(setup.view.distance_m, 2.5);  // the opening fits the image from there
}

TEST(SimulateDemoScan, CloudScansAreSeededPlyWithTheirTruth) {
    const DemoSetup setup = MakeDemoSetup(sim::ContainerKind::kPaperBucket, DemoSensor::kCloud, 3);
    const auto empty = SimulateDemoScan(setup, 0.0, 0, "");
    const auto half = SimulateDemoScan(setup, 0.5, 1, "");
    ASSERT_TRUE(empty.ok() && half.ok());
    ASSERT_TRUE(empty->scan.has_cloud());
    EXPECT_EQ(empty->scan.cloud().data().rfind("ply\n", 0), 0u);
    EXPECT_EQ(empty->opening.corners_size(), 4);
    EXPECT_EQ(empty->opening.pixel_corners_size(), 0);
    EXPECT_DOUBLE_EQ(empty->true_volume_m3, 0.0);
    EXPECT_NEAR(half->true_volume_m3 / half->struck_capacity_m3, 0.5, 0.05);
    EXPECT_EQ(SimulateDemoScan(setup, 0.5, 1, "")->scan.cloud().data(), half->scan.cloud().data());
    EXPECT_NE(SimulateDemoScan(setup, 0.5, 2, "")->scan.cloud().data(), half->scan.cloud().data());
}

TEST(SimulateDemoScan, DepthScansAre16BitPngsOfTheCameraWithTheirTruth) {
    const DemoSetup setup = MakeDemoSetup(sim::ContainerKind::kPaperBucket, DemoSensor::kDepth, 3);
    const auto half = SimulateDemoScan(setup, 0.5, 1, "");
    ASSERT_TRUE(half.ok()) << half.status();
    ASSERT_TRUE(half->scan.has_depth());
    const v1::DepthScan& depth = half->scan.depth();
    EXPECT_EQ(depth.depth().substr(1, 3), "PNG");
    EXPECT_NEAR(depth.camera().cx(), (setup.camera.width - 1) / 2.0, 1e-9);
    EXPECT_GT(depth.camera().fx(), 0.0);
    EXPECT_EQ(half->opening.corners_size(), 4);
    EXPECT_NEAR(half->true_volume_m3 / half->struck_capacity_m3, 0.5, 0.05);
    EXPECT_EQ(SimulateDemoScan(setup, 0.5, 1, "")->scan.depth().depth(), depth.depth());
}

TEST(MakeDemoMesh, IsTheBucketsSurfaceWithItsCornersAndTheScansPoseOfIt) {
    const DemoSetup setup = MakeDemoSetup(sim::ContainerKind::kPaperBucket, DemoSensor::kCloud, 3);
    const DemoMesh mesh = MakeDemoMesh(setup);
    const absl::StatusOr<io::DecodedMesh> decoded = io::DecodeMesh(mesh.stl);
    ASSERT_TRUE(decoded.ok()) << decoded.status();
    EXPECT_GT(decoded->triangles.size(), 12u);
    ASSERT_EQ(mesh.opening.corners_size(), 4);
    // The paper bucket's opening, 2.05 x 0.54 m, in the mesh's frame.
    const v1::Point3& a = mesh.opening.corners(0);
    const v1::Point3& b = mesh.opening.corners(1);
    EXPECT_NEAR(std::hypot(b.x() - a.x(), b.y() - a.y(), b.z() - a.z()), 2.05, 1e-6);
    // The empty scan's pose of that frame puts the corners where the scan has them.
    const auto empty = SimulateDemoScan(setup, 0.0, 0, "");
    ASSERT_TRUE(empty.ok());
    const absl::StatusOr<Pose> pose = server::ToPose(empty->container_pose, "pose");
    ASSERT_TRUE(pose.ok()) << pose.status();
    for (int i = 0; i < 4; ++i) {
        const v1::Point3& m = mesh.opening.corners(i);
        const v1::Point3& s = empty->opening.corners(i);
        const Eigen::Vector3d in_scan = *pose * Eigen::Vector3d(m.x(), m.y(), m.z());
        EXPECT_LT((in_scan - Eigen::Vector3d(s.x(), s.y(), s.z())).norm(), 1e-6) << i;
    }
}

}  // namespace
}  // namespace soilvol::client
