#pragma once

#include <string_view>

#include "absl/status/status.h"
#include "core/common/camera.hpp"

namespace soilvol::depth {

/// How the lens bends rays (OpenCV's models; coefficients in OpenCV's order).
enum class LensModel {
    kPinhole,        ///< no distortion: no coefficients
    kBrownConrady,   ///< radial-tangential ("plumb bob"): k1, k2, p1, p2[, k3[, k4, k5, k6]]
    kKannalaBrandt,  ///< fisheye, equidistant: k1, k2, k3, k4
};

/// What a depth pixel measures.
enum class DepthMeaning {
    kZ,      ///< distance along the optical axis (what most ToF and stereo cameras output)
    kRange,  ///< distance along the pixel's ray (radial distance)
};

/// A depth camera: the frame is OpenCV's (x right, y down, z forward, origin at the centre of
/// projection), pixel (u, v) is the centre of column u, row v.
struct DepthCamera {
    /// fx, fy, cx, cy [px]; `distortion` holds the lens model's coefficients.
    CameraIntrinsics intrinsics;
    LensModel lens = LensModel::kPinhole;
    DepthMeaning meaning = DepthMeaning::kZ;
    /// Metres per stored unit; 0 takes 0.001 for integer images (millimetres) and 1 for float.
    double depth_unit_m = 0.0;
};

/// Focal lengths a depth camera may have [px]: below, a pixel would span more than 45 deg.
inline constexpr double kMinFocalPx = 1.0;
inline constexpr double kMaxFocalPx = 1e6;

/// The stored unit [m] of an image of `bits` (16: integer, 32: float) under `camera`.
double DepthUnitOf(const DepthCamera& camera, int bits);

/// InvalidArgument naming the field (after `field`, e.g. "scan.depth.camera") when `camera`
/// cannot describe an image of width x height: focal lengths in [kMinFocalPx, kMaxFocalPx],
/// principal point finite and within 10 image sides of the image, coefficients finite and as many
/// as the lens model takes, unit finite and >= 0.
absl::Status ValidateDepthCamera(const DepthCamera& camera, int width, int height,
                                 std::string_view field);

}  // namespace soilvol::depth
