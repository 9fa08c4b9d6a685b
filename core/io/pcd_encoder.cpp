#include <lzf.h>

#include <cstdint>
#include <optional>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/scalar_type.hpp"
#include "core/io/xyz_writer.hpp"

namespace soilvol::io {
namespace {

// binary_compressed stores 32-bit sizes; the LZF output buffer below must fit in them too.
constexpr std::uint64_t kMaxCompressibleBytes = 0xF0000000u;

const char* DataName(PcdEncoding encoding) {
    switch (encoding) {
        case PcdEncoding::kAscii:
            return "ascii";
        case PcdEncoding::kBinary:
            return "binary";
        case PcdEncoding::kBinaryCompressed:
            return "binary_compressed";
    }
    return "binary";
}

// VIEWPOINT tx ty tz qw qx qy qz, to 17 significant digits (a double's round trip).
std::string Viewpoint(const Pose& sensor_pose) {
    const Eigen::Vector3d t = sensor_pose.translation();
    const Eigen::Quaterniond q(sensor_pose.linear());
    return absl::StrFormat("VIEWPOINT %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n", t.x(), t.y(),
                           t.z(), q.w(), q.x(), q.y(), q.z());
}

std::string Header(std::size_t count, PcdEncoding encoding, const Pose& sensor_pose) {
    return absl::StrCat(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\n"
        "TYPE F F F\nCOUNT 1 1 1\nWIDTH ",
        count, "\nHEIGHT 1\n", Viewpoint(sensor_pose), "POINTS ", count, "\nDATA ",
        DataName(encoding), "\n");
}

// Sizes, then LZF of all x, all y, all z (little-endian); nullopt when too large.
std::optional<std::string> CompressedBody(const Cloud& points) {
    const std::uint64_t raw_size = static_cast<std::uint64_t>(points.size()) * 12;
    if (raw_size > kMaxCompressibleBytes) return std::nullopt;
    std::string body;
    if (points.empty()) {
        detail::AppendUint32Le(0, &body);
        detail::AppendUint32Le(0, &body);
        return body;
    }
    std::string fields;
    fields.reserve(raw_size);
    for (int axis = 0; axis < 3; ++axis) {
        for (const Eigen::Vector3f& point : points) {
            detail::AppendFloat32(point[axis], /*big_endian=*/false, &fields);
        }
    }
    // LZF grows incompressible data by 1 byte per 32; this buffer cannot run out.
    std::string packed(raw_size + raw_size / 16 + 64, '\0');
    const unsigned int packed_size =
        lzf_compress(fields.data(), static_cast<unsigned int>(fields.size()), packed.data(),
                     static_cast<unsigned int>(packed.size()));
    if (packed_size == 0) return std::nullopt;
    detail::AppendUint32Le(packed_size, &body);
    detail::AppendUint32Le(static_cast<std::uint32_t>(raw_size), &body);
    body.append(packed.data(), packed_size);
    return body;
}

}  // namespace

std::string EncodePcd(const Cloud& points, PcdEncoding encoding, const Pose& sensor_pose) {
    std::optional<std::string> compressed;
    if (encoding == PcdEncoding::kBinaryCompressed) {
        compressed = CompressedBody(points);
        if (!compressed) encoding = PcdEncoding::kBinary;
    }
    std::string out = Header(points.size(), encoding, sensor_pose);
    switch (encoding) {
        case PcdEncoding::kAscii:
            detail::AppendAsciiXyz(points, &out);
            break;
        case PcdEncoding::kBinary:
            detail::AppendBinaryXyz(points, /*big_endian=*/false, &out);
            break;
        case PcdEncoding::kBinaryCompressed:
            out += *compressed;
            break;
    }
    return out;
}

}  // namespace soilvol::io
