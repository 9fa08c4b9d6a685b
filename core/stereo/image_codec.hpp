#pragma once

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"

namespace soilvol::stereo {

/// Decodes an encoded image (PNG, JPEG, TIFF, BMP, PGM: whatever OpenCV reads) of 8 or 16 bits,
/// grey or colour, into 8-bit grey. 16-bit images are shifted right just enough that their
/// largest value fits 8 bits. InvalidArgument naming `field` for empty or undecodable bytes,
/// or a side longer than max_side_px.
absl::StatusOr<GreyImage> DecodeGrey(std::string_view bytes, std::string_view field,
                                     int max_side_px = 8192);

/// Lossless PNG of `image`. InvalidArgument for an empty or inconsistent image.
absl::StatusOr<std::string> EncodePng(const GreyImage& image);

}  // namespace soilvol::stereo
