#pragma once

#include <Eigen/Core>
#include <vector>

namespace soilvol {

/// Pinhole intrinsics [px] with OpenCV's distortion model: coefficients in OpenCV order
/// (k1, k2, p1, p2[, k3[, k4, k5, k6]]); empty means no distortion.
struct CameraIntrinsics {
    double fx = 0.0;
    double fy = 0.0;
    double cx = 0.0;
    double cy = 0.0;
    std::vector<double> distortion;
};

/// A stereo pair's parameters in OpenCV's convention: a point X_left in the left camera frame
/// (x right, y down, z forward) is X_right = R_right_left * X_left + t_right_left_m in the right
/// camera frame; a rig with the right camera b metres to the right has t = (-b, 0, 0).
struct StereoParameters {
    int image_width = 0;
    int image_height = 0;
    CameraIntrinsics left;
    CameraIntrinsics right;
    Eigen::Matrix3d R_right_left = Eigen::Matrix3d::Identity();
    Eigen::Vector3d t_right_left_m = Eigen::Vector3d::Zero();
};

}  // namespace soilvol
