#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"

namespace soilvol::io {

enum class CloudFormat { kPly, kPcd, kRawXyzF32 };

/// A cloud decoded from untrusted bytes.
struct DecodedCloud {
    Cloud points;                       ///< finite points only [m]
    std::size_t dropped_nonfinite = 0;  ///< points with a NaN/Inf coordinate, dropped
    CloudFormat format = CloudFormat::kPly;
    /// The sensor's pose in the cloud's frame (x_cloud = sensor_pose * x_sensor): a PCD's
    /// VIEWPOINT; the identity for PLY, raw xyz and PCDs without one.
    Pose sensor_pose = Pose::Identity();
};

/// Decodes PLY (ascii, binary_little_endian, binary_big_endian; x/y/z float or double),
/// PCD v0.7 (ascii, binary, binary_compressed) or raw little-endian float32 xyz triplets
/// (only when `allow_raw` is set: raw has no magic to detect). The format is detected from
/// the content. Any malformed, truncated, oversized or point-less input gets InvalidArgument
/// with a message naming the problem; nothing is allocated from an unchecked count.
absl::StatusOr<DecodedCloud> DecodeCloud(std::string_view bytes, bool allow_raw = false);

enum class PlyEncoding { kAscii, kBinaryLittleEndian, kBinaryBigEndian };
enum class PcdEncoding { kAscii, kBinary, kBinaryCompressed };

/// Encodes `points` as a PLY file with float x/y/z vertices.
std::string EncodePly(const Cloud& points, PlyEncoding encoding = PlyEncoding::kBinaryLittleEndian);

/// Encodes `points` as a PCD v0.7 file with float x/y/z fields. binary_compressed stores 32-bit
/// sizes, so a cloud of more than ~335 million points is written as binary instead.
/// `sensor_pose` goes into VIEWPOINT (the sensor's pose in the cloud's frame).
std::string EncodePcd(const Cloud& points, PcdEncoding encoding = PcdEncoding::kBinary,
                      const Pose& sensor_pose = Pose::Identity());

/// Encodes `points` as raw little-endian float32 xyz triplets.
std::string EncodeRawXyzF32(const Cloud& points);

}  // namespace soilvol::io
