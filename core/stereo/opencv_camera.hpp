#pragma once

// Private to core/stereo (.cpp files only): camera parameters <-> OpenCV matrices.

#include <opencv2/core.hpp>

#include "core/common/camera.hpp"

namespace soilvol::stereo::detail {

/// The 3x3 CV_64F intrinsic matrix [fx 0 cx; 0 fy cy; 0 0 1].
cv::Mat CameraMatrix(const CameraIntrinsics& intrinsics);

/// The 1xN CV_64F distortion row in OpenCV order; empty for no distortion.
cv::Mat DistortionRow(const CameraIntrinsics& intrinsics);

/// Intrinsics from a 3x3 camera matrix and a distortion vector (any shape, CV_64F).
CameraIntrinsics ToIntrinsics(const cv::Mat& camera_matrix, const cv::Mat& distortion);

}  // namespace soilvol::stereo::detail
