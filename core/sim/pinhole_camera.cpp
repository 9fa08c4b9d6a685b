#include "core/sim/pinhole_camera.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace soilvol::sim {

namespace {

constexpr int kMaxUndistortIterations = 20;
constexpr double kUndistortTolerance = 1e-15;

}  // namespace

PinholeCamera::PinholeCamera(const CameraIntrinsics& intrinsics, const Pose& T_world_camera)
    : fx_(intrinsics.fx),
      fy_(intrinsics.fy),
      cx_(intrinsics.cx),
      cy_(intrinsics.cy),
      T_world_camera_(T_world_camera),
      T_camera_world_(T_world_camera.inverse()) {
    const size_t n = std::min(intrinsics.distortion.size(), k_.size());
    std::copy(intrinsics.distortion.begin(), intrinsics.distortion.begin() + n, k_.begin());
}

Eigen::Vector2d PinholeCamera::Distort(const Eigen::Vector2d& xy) const {
    const double x = xy.x();
    const double y = xy.y();
    const double r2 = x * x + y * y;
    const double radial = (1.0 + ((k_[4] * r2 + k_[1]) * r2 + k_[0]) * r2) /
                          (1.0 + ((k_[7] * r2 + k_[6]) * r2 + k_[5]) * r2);
    return {x * radial + 2.0 * k_[2] * x * y + k_[3] * (r2 + 2.0 * x * x),
            y * radial + k_[2] * (r2 + 2.0 * y * y) + 2.0 * k_[3] * x * y};
}

Eigen::Vector2d PinholeCamera::Undistort(const Eigen::Vector2d& xy_distorted) const {
    // Newton's method on Distort(xy) = xy_distorted (the fixed point of cv::undistortPoints
    // converges to the same root, only slower).
    Eigen::Vector2d xy = xy_distorted;
    for (int i = 0; i < kMaxUndistortIterations; ++i) {
        const double x = xy.x();
        const double y = xy.y();
        const double r2 = x * x + y * y;
        const double numerator = 1.0 + ((k_[4] * r2 + k_[1]) * r2 + k_[0]) * r2;
        const double denominator = 1.0 + ((k_[7] * r2 + k_[6]) * r2 + k_[5]) * r2;
        const double radial = numerator / denominator;
        const double d_numerator = k_[0] + (2.0 * k_[1] + 3.0 * k_[4] * r2) * r2;
        const double d_denominator = k_[5] + (2.0 * k_[6] + 3.0 * k_[7] * r2) * r2;
        const double d_radial =  // d radial / d r2
            (d_numerator * denominator - numerator * d_denominator) / (denominator * denominator);
        Eigen::Matrix2d jacobian;
        jacobian << radial + 2.0 * x * x * d_radial + 2.0 * k_[2] * y + 6.0 * k_[3] * x,
            2.0 * x * y * d_radial + 2.0 * k_[2] * x + 2.0 * k_[3] * y,
            2.0 * x * y * d_radial + 2.0 * k_[2] * x + 2.0 * k_[3] * y,
            radial + 2.0 * y * y * d_radial + 6.0 * k_[2] * y + 2.0 * k_[3] * x;
        const Eigen::Vector2d step = jacobian.inverse() * (Distort(xy) - xy_distorted);
        xy -= step;
        if (!(step.cwiseAbs().maxCoeff() > kUndistortTolerance)) break;
    }
    return xy;
}

Eigen::Vector2d PinholeCamera::Project(const Eigen::Vector3d& X_world) const {
    const Eigen::Vector3d X = T_camera_world_ * X_world;
    if (!(X.z() > 0.0)) return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    const Eigen::Vector2d xy = Distort(X.head<2>() / X.z());
    return {fx_ * xy.x() + cx_, fy_ * xy.y() + cy_};
}

Eigen::Vector3d PinholeCamera::Direction(const Eigen::Vector2d& pixel) const {
    const Eigen::Vector2d xy =
        Undistort(Eigen::Vector2d((pixel.x() - cx_) / fx_, (pixel.y() - cy_) / fy_));
    return T_world_camera_.linear() * Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

std::array<PinholeCamera, 2> RigCameras(const StereoRigSpec& rig) {
    const StereoParameters parameters = RigParameters(rig);
    Pose T_right_left = Pose::Identity();
    T_right_left.linear() = parameters.R_right_left;
    T_right_left.translation() = parameters.t_right_left_m;
    return {PinholeCamera(parameters.left),
            PinholeCamera(parameters.right, T_right_left.inverse())};
}

}  // namespace soilvol::sim
