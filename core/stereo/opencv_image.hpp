#pragma once

// Private to core/stereo (.cpp files only): GreyImage <-> cv::Mat and decoding to cv::Mat.

#include <opencv2/core.hpp>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"

namespace soilvol::stereo::detail {

/// A CV_8UC1 view of `image` without a copy: valid while `image` lives and keeps its size;
/// write through it only when `image` is not const.
cv::Mat WrapGrey(const GreyImage& image);

/// A copy of a CV_8UC1 matrix (continuous or not) as a GreyImage.
GreyImage ToGreyImage(const cv::Mat& grey);

/// An image as stored (any depth and channel count), after the header's size was checked
/// against max_side_px and kMaxImagePixels. InvalidArgument naming `field` otherwise; sets
/// `*too_large` (when given) to whether the image was refused for its size.
absl::StatusOr<cv::Mat> DecodeMat(std::string_view bytes, std::string_view field,
                                  int max_side_px = 8192, bool* too_large = nullptr);

/// DecodeGrey's work, returning CV_8UC1; same checks and messages. Sets `*too_large` (when
/// given) to whether the image was refused for its size.
absl::StatusOr<cv::Mat> DecodeGreyMat(std::string_view bytes, std::string_view field,
                                      int max_side_px = 8192, bool* too_large = nullptr);

}  // namespace soilvol::stereo::detail
