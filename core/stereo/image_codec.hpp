#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"

namespace soilvol::stereo {

/// Pixels one image may hold (a 24-megapixel camera): a larger one is refused from its header.
inline constexpr std::int64_t kMaxImagePixels = 24'000'000;

/// Decodes an encoded PNG, JPEG, BMP, PNM (P1-P6) or TIFF image of 8 or 16 bits, grey or
/// colour, into 8-bit grey; the size its header declares is checked before anything is
/// decoded, and other formats (WebP, JPEG 2000, OpenEXR, ...) are refused. 16-bit images are
/// shifted right just enough that their largest value fits 8 bits. InvalidArgument naming
/// `field` for empty, undecodable or other-format bytes, a side longer than max_side_px, or
/// more than kMaxImagePixels pixels.
absl::StatusOr<GreyImage> DecodeGrey(std::string_view bytes, std::string_view field,
                                     int max_side_px = 8192);

/// Decodes a one-channel image as stored, for depth, confidence and amplitude images: 8 or
/// 16-bit unsigned (PNG, TIFF, PNM) or 32-bit float (TIFF). Size checks as DecodeGrey's;
/// InvalidArgument naming `field` for more than one channel or another sample type.
absl::StatusOr<ScalarImage> DecodeScalar(std::string_view bytes, std::string_view field,
                                         int max_side_px = 8192);

/// Lossless encoding of a one-channel image as its `bits` say: 8 or 16 bits as PNG (values
/// rounded and clamped to the type), 32 as float TIFF. InvalidArgument for an empty or
/// inconsistent image or other bits.
absl::StatusOr<std::string> EncodeScalar(const ScalarImage& image);

/// Lossless PNG of `image`. InvalidArgument for an empty or inconsistent image.
absl::StatusOr<std::string> EncodePng(const GreyImage& image);
absl::StatusOr<std::string> EncodePng(const RgbImage& image);

}  // namespace soilvol::stereo
