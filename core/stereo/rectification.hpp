#pragma once

// Private to core/stereo: parameter checks and rectification shared by both calibration paths.

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/stereo/calibration.hpp"

namespace soilvol::stereo::detail {

inline constexpr int kMinImageSidePx = 16;
inline constexpr int kMaxImageSidePx = 8192;

/// OK when every field of `parameters` is usable; InvalidArgument naming the first bad field.
absl::Status ValidateStereoParameters(const StereoParameters& parameters);

/// Validates `parameters`, then rectifies them with cv::stereoRectify (CALIB_ZERO_DISPARITY,
/// alpha -1). Fills parameters, R1, R2, P1, P2, Q, baseline_m, focal_px; leaves the chessboard
/// figures and source empty. alpha -1 keeps the rectified focal length at the mean of the
/// cameras' fy, whatever the distortion model does beyond the area the boards covered: depth
/// resolution stays native and the result is stable. alpha 0 (only valid pixels) and 1 (every
/// source pixel) rescale from the extrapolated image border instead; on OpenCV's sample pairs
/// they give 515.6 and 428.8 px against 535.2 px.
absl::StatusOr<StereoCalibration> Rectify(const StereoParameters& parameters);

}  // namespace soilvol::stereo::detail
