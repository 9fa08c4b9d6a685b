#include "core/stereo/rectification.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <utility>
#include <vector>

#include "core/sim/stereo_renderer.hpp"
#include "core/stereo/reconstructor.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo::detail {
namespace {

// The simulated rig: 640x480, f = 554 px, 10 cm baseline, the right camera turned by
// (0.3, -0.5, 0.2) deg, k1 = -0.08, k2 = 0.02 on both cameras.
StereoParameters Rig() { return sim::RigParameters(sim::StereoRigSpec{}); }

// cv::undistortPoints inverts the distortion by 5 fixed-point steps; each shrinks the error by
// |3 k1 r^2 + 5 k2 r^4| <= 0.15 at this lens's image corners (r^2 = 0.52), from a displacement of
// at most 16 px: 16 x 0.15^5 = 0.0012 px. 0.01 px holds that with room.
constexpr double kUndistortPx = 0.01;

// The right camera's raw pixel in the rectified right image (the reconstructor rectifies only
// the left): OpenCV's undistortion with R2 and P2.
Eigen::Vector2d RectifyRightPixel(const StereoCalibration& c, const Eigen::Vector2d& raw) {
    const CameraIntrinsics& k = c.parameters.right;
    const cv::Matx33d camera(k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0);
    cv::Mat r2, p2;
    cv::eigen2cv(c.R2, r2);
    cv::eigen2cv(Eigen::Matrix<double, 3, 4>(c.P2), p2);
    std::vector<cv::Point2d> in{{raw.x(), raw.y()}}, out;
    cv::undistortPoints(in, out, camera, k.distortion, r2, p2);
    return {out[0].x, out[0].y};
}

// Rectified left and right cameras differ by a translation along x only: both are turned by
// their R into one orientation (R2 R_right_left = R1), the right centre sits at (-B, 0, 0) from
// the left in rectified right coordinates (R2 t = (-B, 0, 0)), and P2 = P1 + (f Tx) e_x.
TEST(RectificationTest, RectifiedCamerasShareOneOrientationAndAnXBaseline) {
    const StereoParameters rig = Rig();
    const auto c = Rectify(rig);
    ASSERT_TRUE(c.ok()) << c.status();
    EXPECT_LT((c->R2 * rig.R_right_left - c->R1).cwiseAbs().maxCoeff(), 1e-12);
    const Eigen::Vector3d t = c->R2 * rig.t_right_left_m;
    EXPECT_NEAR(t.x(), -0.10, 1e-12);
    EXPECT_NEAR(t.tail<2>().norm(), 0.0, 1e-12);
    for (const Eigen::Matrix3d& r : {c->R1, c->R2}) {
        EXPECT_LT((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
        EXPECT_NEAR(r.determinant(), 1.0, 1e-12);
    }
    EXPECT_LT((c->P2.leftCols<3>() - c->P1.leftCols<3>()).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_NEAR(c->P2(0, 3), -c->focal_px * 0.10, 1e-9);
    EXPECT_NEAR(c->baseline_m, 0.10, 1e-15);
}

// alpha -1 keeps the rectified focal length at the mean of the cameras' fy (the header's
// promise), and the chessboard figures and the source stay empty.
TEST(RectificationTest, FocalLengthIsTheMeanFyAndChessboardFiguresStayEmpty) {
    StereoParameters rig = Rig();
    rig.right.fy *= 1.02;
    rig.right.fx *= 1.02;
    const auto c = Rectify(rig);
    ASSERT_TRUE(c.ok()) << c.status();
    EXPECT_NEAR(c->focal_px, 0.5 * (rig.left.fy + rig.right.fy), 1e-9);
    EXPECT_EQ(c->focal_px, c->P1(0, 0));
    EXPECT_EQ(c->source, "");
    EXPECT_TRUE(c->pairs.empty());
    EXPECT_TRUE(c->skipped.empty());
    EXPECT_EQ(c->rms_reprojection_px, 0.0);
}

// Points the renderer projects (its own pinhole and distortion code, not OpenCV's) land on one
// rectified row in both images, and their rectified disparity reprojects through Q to the point
// in the rectified left frame. Rows agree to the undistortion's accuracy; the point to the depth
// that error makes, Z^2 / (f B) x 0.01 px (< 2 mm at 5 m).
TEST(RectificationTest, ProjectionsOfAPointShareTheirRectifiedRowAndReprojectToIt) {
    const sim::StereoRigSpec spec;
    const auto c = Rectify(Rig());
    ASSERT_TRUE(c.ok()) << c.status();
    const auto reconstructor = StereoReconstructor::Create(*c);
    ASSERT_TRUE(reconstructor.ok()) << reconstructor.status();
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> depth(1.0, 5.0);
    std::uniform_real_distribution<double> across(-0.5, 0.5);
    int checked = 0;
    for (int i = 0; i < 200; ++i) {
        const double z = depth(rng);
        const Eigen::Vector3d x_left(across(rng) * z, across(rng) * 0.75 * z, z);
        const Eigen::Vector2d raw_left = sim::ProjectLeft(spec, x_left);
        const Eigen::Vector2d raw_right = sim::ProjectRight(spec, x_left);
        const auto in_image = [&](const Eigen::Vector2d& p) {
            return p.allFinite() && p.x() >= 0 && p.y() >= 0 && p.x() < 640 && p.y() < 480;
        };
        if (!in_image(raw_left) || !in_image(raw_right)) continue;
        ++checked;
        const Eigen::Vector2d left = reconstructor->RectifyLeftPixel(raw_left);
        const Eigen::Vector2d right = RectifyRightPixel(*c, raw_right);
        EXPECT_NEAR(left.y(), right.y(), kUndistortPx) << "point " << i;
        const Eigen::Vector3d back =
            reconstructor->Reproject(left.x(), left.y(), left.x() - right.x());
        const Eigen::Vector3d truth = c->R1 * x_left;
        EXPECT_LT((back - truth).norm(), z * z / (c->focal_px * c->baseline_m) * kUndistortPx +
                                             z / c->focal_px * kUndistortPx)
            << "point " << i;
    }
    EXPECT_GT(checked, 100);
}

// Rectify then unrectify: a rectified pixel's ray, turned back into the left camera (R1^T) and
// projected through the lens by the renderer, is the raw pixel that rectifies to it.
TEST(RectificationTest, RectifiedPixelsRoundTripThroughTheLens) {
    const sim::StereoRigSpec spec;
    const auto c = Rectify(Rig());
    ASSERT_TRUE(c.ok()) << c.status();
    const auto reconstructor = StereoReconstructor::Create(*c);
    ASSERT_TRUE(reconstructor.ok()) << reconstructor.status();
    const double f = c->P1(0, 0), cx = c->P1(0, 2), cy = c->P1(1, 2);
    for (int v = 20; v < 480; v += 40) {
        for (int u = 20; u < 640; u += 40) {
            const Eigen::Vector3d ray((u - cx) / f, (v - cy) / f, 1.0);
            const Eigen::Vector2d raw = sim::ProjectLeft(spec, c->R1.transpose() * ray);
            const Eigen::Vector2d back = reconstructor->RectifyLeftPixel(raw);
            EXPECT_LT((back - Eigen::Vector2d(u, v)).norm(), kUndistortPx) << u << ", " << v;
            EXPECT_LT((reconstructor->ProjectRectified(3.0 * ray) - Eigen::Vector2d(u, v)).norm(),
                      1e-9);
        }
    }
}

TEST(RectificationTest, ValidRigsPassAndInvalidOnesAreRefusedBeforeOpenCv) {
    EXPECT_TRUE(ValidateStereoParameters(Rig()).ok());
    const std::pair<const char*, void (*)(StereoParameters&)> cases[] = {
        {"image_width", [](StereoParameters& p) { p.image_width = kMinImageSidePx - 1; }},
        {"image_height", [](StereoParameters& p) { p.image_height = kMaxImageSidePx + 1; }},
        {"left.fx", [](StereoParameters& p) { p.left.fx = std::nan(""); }},
        {"right.cy", [](StereoParameters& p) { p.right.cy = -0.5; }},
        {"R_right_left", [](StereoParameters& p) { p.R_right_left(1, 1) = -1.0; }},
        {"t_right_left_m is zero", [](StereoParameters& p) { p.t_right_left_m.setZero(); }},
    };
    for (const auto& [field, spoil] : cases) {
        StereoParameters rig = Rig();
        spoil(rig);
        EXPECT_TRUE(test::HasError(ValidateStereoParameters(rig),
                                   absl::StatusCode::kInvalidArgument, field));
        EXPECT_TRUE(test::IsInvalidWith(Rectify(rig), field));
    }
}

// A rig that passes every field check but whose cameras look along the baseline (the right camera
// straight ahead of the left) has no rectification that keeps both images: it must come back as
// an error or a finite calibration, never a crash or NaNs.
TEST(RectificationTest, ABaselineAlongTheViewIsAnErrorOrFinite) {
    StereoParameters rig = Rig();
    rig.R_right_left.setIdentity();
    rig.t_right_left_m = Eigen::Vector3d(0.0, 0.0, -0.1);
    const auto c = Rectify(rig);
    if (c.ok()) {
        EXPECT_TRUE(c->R1.allFinite() && c->P1.allFinite() && c->Q.allFinite());
        EXPECT_GT(c->focal_px, 0.0);
    } else {
        EXPECT_EQ(c.status().code(), absl::StatusCode::kInvalidArgument) << c.status();
    }
}

}  // namespace
}  // namespace soilvol::stereo::detail
