#pragma once

#include <Eigen/Core>
#include <array>

#include "core/common/camera.hpp"
#include "core/common/types.hpp"
#include "core/sim/stereo_renderer.hpp"

namespace soilvol::sim {

/// A posed pinhole camera with OpenCV's distortion model (k1, k2, p1, p2[, k3[, k4, k5, k6]];
/// further coefficients are ignored). World frame: whatever `T_world_camera` maps into.
class PinholeCamera {
  public:
    explicit PinholeCamera(const CameraIntrinsics& intrinsics,
                           const Pose& T_world_camera = Pose::Identity());

    /// Distorted pixel of a world point, as cv::projectPoints computes it; NaN when the point is
    /// not in front of the camera.
    Eigen::Vector2d Project(const Eigen::Vector3d& X_world) const;
    /// Unit world direction of the ray through a distorted pixel (the distortion is inverted by
    /// Newton's method to machine precision).
    Eigen::Vector3d Direction(const Eigen::Vector2d& pixel) const;
    /// Camera centre in the world frame [m].
    Eigen::Vector3d Centre() const { return T_world_camera_.translation(); }

  private:
    Eigen::Vector2d Distort(const Eigen::Vector2d& xy) const;
    Eigen::Vector2d Undistort(const Eigen::Vector2d& xy_distorted) const;

    double fx_, fy_, cx_, cy_;
    std::array<double, 8> k_{};  // k1, k2, p1, p2, k3, k4, k5, k6
    Pose T_world_camera_;
    Pose T_camera_world_;
};

/// The left (at the origin of the left camera frame) and right cameras of `rig`.
std::array<PinholeCamera, 2> RigCameras(const StereoRigSpec& rig);

}  // namespace soilvol::sim
