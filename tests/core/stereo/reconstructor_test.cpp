#include "core/stereo/reconstructor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "core/sim/stereo_renderer.hpp"
#include "core/stereo/image_codec.hpp"

namespace soilvol::stereo {
namespace {

StereoCalibration Exact(const sim::StereoRigSpec& rig) {
    auto calibration = CalibrationFromParameters(sim::RigParameters(rig));
    EXPECT_TRUE(calibration.ok()) << calibration.status();
    return *calibration;
}

// Uploaded pixel -> rectified pixel agrees with projecting the point in the rectified frame,
// and Q reprojection inverts the projection at the true disparity.
TEST(ReconstructorTest, PixelMappingsAgreeWithTheRig) {
    const sim::StereoRigSpec rig;
    const StereoCalibration calibration = Exact(rig);
    const auto stereo = StereoReconstructor::Create(calibration);
    ASSERT_TRUE(stereo.ok()) << stereo.status();
    for (const Eigen::Vector3d& X_left :
         {Eigen::Vector3d(0.0, 0.0, 2.5), Eigen::Vector3d(-0.8, 0.5, 3.0),
          Eigen::Vector3d(1.0, -0.6, 2.2)}) {
        const Eigen::Vector3d X_rect = calibration.R1 * X_left;
        const Eigen::Vector2d rect = stereo->ProjectRectified(X_rect);
        EXPECT_LT((stereo->RectifyLeftPixel(sim::ProjectLeft(rig, X_left)) - rect).norm(), 0.02);
        const double d = calibration.focal_px * calibration.baseline_m / X_rect.z();
        EXPECT_LT((stereo->Reproject(rect.x(), rect.y(), d) - X_rect).norm(), 1e-9);
    }
}

// The empty paper bucket, exact calibration, no motion: the reconstructed floor lies on the
// true floor (z = -0.6 in the container frame) within the depth resolution at 3 m.
TEST(ReconstructorTest, RenderedFloorComesBackAtItsTrueHeight) {
    const sim::StereoRigSpec rig;
    const StereoCalibration calibration = Exact(rig);
    sim::SceneSpec spec;
    spec.sensor = sim::ViewpointFor(spec.container);
    spec.sensor.distance_m = 3.0;
    const sim::StereoScene scene = sim::RenderStereoScene(spec, rig);
    const auto stereo = StereoReconstructor::Create(calibration);
    ASSERT_TRUE(stereo.ok());
    const auto cloud = stereo->Reconstruct(scene.left, scene.right);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    Pose T_rect_left = Pose::Identity();
    T_rect_left.linear() = calibration.R1;
    const Pose T_container_rect = (T_rect_left * scene.T_left_container).inverse();
    std::vector<double> floor;
    for (const Eigen::Vector3f& p : cloud->points) {
        const Eigen::Vector3d q = T_container_rect * p.cast<double>();
        if (std::abs(q.x()) < 0.9 && std::abs(q.y()) < 0.2 && q.z() < -0.4) floor.push_back(q.z());
    }
    ASSERT_GT(floor.size(), 5000u);
    std::nth_element(floor.begin(), floor.begin() + floor.size() / 2, floor.end());
    EXPECT_NEAR(floor[floor.size() / 2], -0.6, 0.015);
    EXPECT_GT(cloud->timings.match_ms, 0.0);
}

TEST(ReconstructorTest, BadConfigurationsAndImagesAreInvalidArgument) {
    const StereoCalibration calibration = Exact({});
    ReconstructConfig ranges;
    ranges.max_range_m = 0.2;
    EXPECT_EQ(StereoReconstructor::Create(calibration, ranges).status().code(),
              absl::StatusCode::kInvalidArgument);
    ReconstructConfig blocks;
    blocks.sgbm.block_size = 4;
    EXPECT_EQ(StereoReconstructor::Create(calibration, blocks).status().code(),
              absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(StereoReconstructor::Create(StereoCalibration{}).status().code(),
              absl::StatusCode::kInvalidArgument);

    const auto stereo = StereoReconstructor::Create(calibration);
    ASSERT_TRUE(stereo.ok());
    const GreyImage small{64, 48, std::vector<uint8_t>(64 * 48, 7)};
    const auto png = EncodePng(small);
    ASSERT_TRUE(png.ok());
    const auto wrong_size = stereo->Reconstruct(*png, *png);
    EXPECT_EQ(wrong_size.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(wrong_size.status().message().find("left"), std::string::npos);
    EXPECT_EQ(stereo->Reconstruct("", "").status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(stereo->Reconstruct(std::string(1000, '\x89'), *png).status().code(),
              absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace soilvol::stereo
