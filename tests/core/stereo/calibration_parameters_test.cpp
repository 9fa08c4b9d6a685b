#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/stereo/calibration.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo {
namespace {

using test::IsInvalidWith;

constexpr double kNotANumber = std::numeric_limits<double>::quiet_NaN();
constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kBaselineM = 0.1;
constexpr double kFocalPx = 554.0;

// Two 640 x 480 cameras with fx = fy = 554 px and webcam-like distortion, the right one
// 0.1 m to the right of the left one and turned by 1.1 degrees.
StereoParameters SyntheticRig() {
    StereoParameters rig;
    rig.image_width = 640;
    rig.image_height = 480;
    rig.left = {kFocalPx, kFocalPx, 321.5, 238.0, {-0.12, 0.03, 0.001, -0.0005, 0.0}};
    rig.right = {kFocalPx, kFocalPx, 317.0, 243.5, {-0.10, 0.02, -0.0008, 0.0004}};
    rig.R_right_left =
        Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.2, 1.0, 0.1).normalized()).toRotationMatrix();
    const Eigen::Vector3d right_centre_in_left(kBaselineM, 0.0, 0.0);
    rig.t_right_left_m = -rig.R_right_left * right_centre_in_left;
    return rig;
}

cv::Mat CameraMatrix(const CameraIntrinsics& c) {
    return (cv::Mat_<double>(3, 3) << c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0);
}

TEST(CalibrationFromParametersTest, SyntheticRigHasOpenCvRectification) {
    const auto calibration = CalibrationFromParameters(SyntheticRig());
    ASSERT_TRUE(calibration.ok()) << calibration.status();
    EXPECT_EQ(calibration->source, "parameters");
    EXPECT_NEAR(calibration->baseline_m, kBaselineM, 1e-15);
    EXPECT_NEAR(calibration->focal_px, kFocalPx, 1e-9);  // alpha -1: the cameras' mean fy
    EXPECT_EQ(calibration->focal_px, calibration->P1(0, 0));
    EXPECT_EQ(calibration->Q(2, 3), calibration->focal_px);
    // t = (-b, 0, 0) after rectification: Q(3, 2) = -1 / Tx = 1 / b, P2(0, 3) = f * Tx.
    EXPECT_NEAR(calibration->Q(3, 2), 1.0 / kBaselineM, 1e-9);
    EXPECT_NEAR(calibration->Q(3, 3), 0.0, 1e-12);
    EXPECT_NEAR(calibration->P2(0, 3), -kFocalPx * kBaselineM, 1e-9);
    EXPECT_NEAR(
        (calibration->R1.transpose() * calibration->R1 - Eigen::Matrix3d::Identity()).norm(), 0.0,
        1e-12);
    EXPECT_TRUE(calibration->pairs.empty());
    EXPECT_EQ(calibration->rms_reprojection_px, 0.0);
}

// Points seen by both cameras land on the same rectified row, and Q takes their disparity
// back to the point (in the rectified left frame, R1 * X_left).
TEST(CalibrationFromParametersTest, RectifiedRowsAgreeAndQTriangulates) {
    const StereoParameters rig = SyntheticRig();
    const auto calibration = CalibrationFromParameters(rig);
    ASSERT_TRUE(calibration.ok()) << calibration.status();

    std::mt19937 rng(17);
    std::uniform_real_distribution<double> lateral(-0.8, 0.8);
    std::uniform_real_distribution<double> depth(1.5, 5.0);
    std::vector<cv::Point3d> points;
    for (int i = 0; i < 60; ++i) {
        const double z = depth(rng);
        points.emplace_back(lateral(rng) * z * 0.5, lateral(rng) * z * 0.35, z);
    }
    cv::Mat rotation, rvec, tvec;
    cv::eigen2cv(rig.R_right_left, rotation);
    cv::Rodrigues(rotation, rvec);
    cv::eigen2cv(rig.t_right_left_m, tvec);
    std::vector<cv::Point2d> left, right;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), CameraMatrix(rig.left),
                      rig.left.distortion, left);
    cv::projectPoints(points, rvec, tvec, CameraMatrix(rig.right), rig.right.distortion, right);

    cv::Mat r1, r2, p1, p2;
    cv::eigen2cv(calibration->R1, r1);
    cv::eigen2cv(calibration->R2, r2);
    cv::eigen2cv(Eigen::Matrix<double, 3, 4>(calibration->P1), p1);
    cv::eigen2cv(Eigen::Matrix<double, 3, 4>(calibration->P2), p2);
    const cv::TermCriteria exact(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-12);
    std::vector<cv::Point2d> left_rectified, right_rectified;
    cv::undistortPoints(left, left_rectified, CameraMatrix(rig.left), rig.left.distortion, r1, p1,
                        exact);
    cv::undistortPoints(right, right_rectified, CameraMatrix(rig.right), rig.right.distortion, r2,
                        p2, exact);

    int checked = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        const bool inside = left[i].inside(cv::Rect2d(0, 0, 640, 480)) &&
                            right[i].inside(cv::Rect2d(0, 0, 640, 480));
        if (!inside) continue;
        ++checked;
        EXPECT_NEAR(left_rectified[i].y, right_rectified[i].y, 1e-6) << i;
        const double disparity = left_rectified[i].x - right_rectified[i].x;
        const Eigen::Vector4d homogeneous =
            calibration->Q *
            Eigen::Vector4d(left_rectified[i].x, left_rectified[i].y, disparity, 1.0);
        const Eigen::Vector3d rectified = homogeneous.head<3>() / homogeneous.w();
        const Eigen::Vector3d point(points[i].x, points[i].y, points[i].z);
        EXPECT_NEAR((calibration->R1.transpose() * rectified - point).norm(), 0.0, 1e-8 * point.z())
            << i;
    }
    EXPECT_GT(checked, 30);
}

TEST(CalibrationFromParametersTest, EveryDistortionCountOpenCvKnowsIsAccepted) {
    for (const std::size_t count : {0u, 4u, 5u, 8u}) {
        StereoParameters rig = SyntheticRig();
        rig.left.distortion.resize(count, 0.001);
        rig.right.distortion.resize(count, -0.001);
        const auto calibration = CalibrationFromParameters(rig);
        EXPECT_TRUE(calibration.ok()) << count << ": " << calibration.status();
    }
}

struct BadField {
    std::string expected;  // substring of the message
    std::function<void(StereoParameters&)> spoil;
};

TEST(CalibrationFromParametersTest, EachInvalidFieldIsNamed) {
    const std::vector<BadField> cases = {
        {"image_width must be in [16, 8192], got 15", [](auto& p) { p.image_width = 15; }},
        {"image_width must be in [16, 8192], got 8193", [](auto& p) { p.image_width = 8193; }},
        {"image_height must be in [16, 8192], got 0", [](auto& p) { p.image_height = 0; }},
        {"left.fx must be positive and finite", [](auto& p) { p.left.fx = 0.0; }},
        {"left.fx must be positive and finite", [](auto& p) { p.left.fx = -554.0; }},
        {"left.fx must be positive and finite", [](auto& p) { p.left.fx = kNotANumber; }},
        {"left.fy must be positive and finite", [](auto& p) { p.left.fy = kInfinity; }},
        {"right.fx must be positive and finite", [](auto& p) { p.right.fx = kNotANumber; }},
        {"right.fy must be positive and finite", [](auto& p) { p.right.fy = 0.0; }},
        {"left.cx must be inside the image [0, 640]", [](auto& p) { p.left.cx = -1.0; }},
        {"right.cx must be inside the image [0, 640]", [](auto& p) { p.right.cx = 700.0; }},
        {"left.cy must be inside the image [0, 480]", [](auto& p) { p.left.cy = kNotANumber; }},
        {"right.cy must be inside the image [0, 480]", [](auto& p) { p.right.cy = 481.0; }},
        {"left.distortion must have 0, 4, 5 or 8 coefficients, got 3",
         [](auto& p) { p.left.distortion.resize(3); }},
        {"right.distortion must have 0, 4, 5 or 8 coefficients, got 14",
         [](auto& p) { p.right.distortion.resize(14); }},
        {"left.distortion[1] must be finite", [](auto& p) { p.left.distortion[1] = kNotANumber; }},
        {"right.distortion[3] must be finite", [](auto& p) { p.right.distortion[3] = -kInfinity; }},
        {"R_right_left is not a proper rotation (det=-1",
         [](auto& p) { p.R_right_left.col(0) *= -1.0; }},
        {"R_right_left is not a proper rotation", [](auto& p) { p.R_right_left *= 1.001; }},
        {"R_right_left is not a proper rotation", [](auto& p) { p.R_right_left(0, 1) += 1e-5; }},
        {"R_right_left must be finite", [](auto& p) { p.R_right_left(2, 2) = kNotANumber; }},
        {"t_right_left_m is zero", [](auto& p) { p.t_right_left_m.setZero(); }},
        {"t_right_left_m must be finite", [](auto& p) { p.t_right_left_m.y() = kInfinity; }},
        // Found by fuzz_calibration_record: finite values whose norm overflows to infinity.
        {"t_right_left_m gives a baseline past 100 m",
         [](auto& p) { p.t_right_left_m << -0.1, -1.06e178, -1.06e178; }},
        {"t_right_left_m gives a baseline past 100 m", [](auto& p) { p.t_right_left_m.x() = 101; }},
        {"left.fx must be at most 1e+06 px", [](auto& p) { p.left.fx = 2e6; }},
        {"right.fy must be at most 1e+06 px", [](auto& p) { p.right.fy = 1e300; }},
    };
    for (const BadField& bad : cases) {
        StereoParameters rig = SyntheticRig();
        bad.spoil(rig);
        EXPECT_TRUE(IsInvalidWith(CalibrationFromParameters(rig), bad.expected));
    }
}

}  // namespace
}  // namespace soilvol::stereo
