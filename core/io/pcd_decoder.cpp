#include "core/io/pcd_decoder.hpp"

#include <lzf.h>

#include <array>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/point_sink.hpp"
#include "core/io/scalar_type.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

// PCL writes binary data in host order; PCD files in practice are little-endian.
constexpr bool kSwap = !kHostIsLittleEndian;
// An LZF back-reference of 3 bytes yields at most 264 bytes, so LZF expands < 100x.
constexpr std::uint64_t kMaxLzfRatio = 100;

absl::Status BodyError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PCD body: ", what));
}

// POINTS * point size [bytes], which the header parser has not multiplied yet.
absl::StatusOr<std::uint64_t> DataSize(const PcdHeader& header) {
    std::uint64_t size = 0;
    if (!CheckedMul(header.points, header.point_size, &size)) {
        return BodyError(absl::StrCat("POINTS ", header.points, " times point size ",
                                      header.point_size, " bytes overflows"));
    }
    return size;
}

// Offset [bytes] of the first value of each field: within a point (`points` = 1), or within
// the field-by-field layout of binary_compressed (`points` = POINTS; fits, as DataSize does).
std::array<std::uint64_t, 3> XyzOffsets(const PcdHeader& header, std::uint64_t points) {
    std::array<std::uint64_t, 3> offsets{};
    for (std::size_t axis = 0; axis < 3; ++axis) {
        for (std::size_t f = 0; f < header.xyz_field[axis]; ++f) {
            offsets[axis] += header.fields[f].size * header.fields[f].count * points;
        }
    }
    return offsets;
}

std::array<ScalarType, 3> XyzTypes(const PcdHeader& header) {
    std::array<ScalarType, 3> types{};
    for (std::size_t axis = 0; axis < 3; ++axis) {
        types[axis] = CoordinateType(header.fields[header.xyz_field[axis]]);
    }
    return types;
}

absl::StatusOr<DecodedCloud> DecodeBinaryBody(const PcdHeader& header, std::string_view body) {
    SOILVOL_ASSIGN_OR_RETURN(const std::uint64_t needed, DataSize(header));
    if (needed > body.size()) {
        return BodyError(absl::StrCat("POINTS ", header.points, " needs ", needed,
                                      " bytes but only ", body.size(), " follow"));
    }
    const auto [ox, oy, oz] = XyzOffsets(header, 1);
    const auto [tx, ty, tz] = XyzTypes(header);
    PointSink sink(CloudFormat::kPcd, header.points);
    for (std::uint64_t i = 0; i < header.points; ++i) {
        const char* point = body.data() + i * header.point_size;
        sink.Add(LoadCoordinate(point + ox, tx, kSwap), LoadCoordinate(point + oy, ty, kSwap),
                 LoadCoordinate(point + oz, tz, kSwap));
    }
    return std::move(sink).Finish();
}

}  // namespace

absl::StatusOr<DecodedCloud> DecodePcd(std::string_view bytes) {
    SOILVOL_ASSIGN_OR_RETURN(const PcdHeader header, ParsePcdHeader(bytes));
    const std::string_view body = bytes.substr(header.body_offset);
    absl::StatusOr<DecodedCloud> cloud = BodyError("unknown DATA kind");
    switch (header.data) {
        case PcdData::kAscii:
            cloud = DecodePcdAsciiBody(header, body);
            break;
        case PcdData::kBinary:
            cloud = DecodeBinaryBody(header, body);
            break;
        case PcdData::kBinaryCompressed:
            cloud = DecodePcdCompressedBody(header, body);
            break;
    }
    if (cloud.ok()) cloud->sensor_pose = header.viewpoint;
    return cloud;
}

absl::StatusOr<DecodedCloud> DecodePcdCompressedBody(const PcdHeader& header,
                                                     std::string_view body) {
    // Step 1: validate both sizes against the header and the bytes before allocating.
    if (body.size() < 8) return BodyError("binary_compressed data lacks its two size words");
    const std::uint32_t compressed = LoadUnsigned<std::uint32_t>(body.data(), kSwap);
    const std::uint32_t uncompressed = LoadUnsigned<std::uint32_t>(body.data() + 4, kSwap);
    body.remove_prefix(8);
    if (compressed == 0 || compressed > body.size()) {
        return BodyError(
            absl::StrCat("compressed size ", compressed, " but ", body.size(), " bytes follow"));
    }
    SOILVOL_ASSIGN_OR_RETURN(const std::uint64_t expected, DataSize(header));
    if (uncompressed != expected) {
        return BodyError(absl::StrCat("uncompressed size ", uncompressed,
                                      " != POINTS * point size = ", expected));
    }
    if (uncompressed > detail::kMaxDecodedBytes) {
        return BodyError(absl::StrCat("uncompressed size ", uncompressed, " is more than the ",
                                      detail::kMaxDecodedBytes, " bytes a scan may expand to"));
    }
    if (uncompressed > kMaxLzfRatio * compressed) {
        return BodyError(absl::StrCat("uncompressed size ", uncompressed, " is implausible for ",
                                      compressed, " compressed bytes (LZF expands < ", kMaxLzfRatio,
                                      "x)"));
    }
    // Step 2: decompress; the result must fill the buffer exactly.
    std::string fields(uncompressed, '\0');
    const unsigned int written =
        lzf_decompress(body.data(), compressed, fields.data(), uncompressed);
    if (written != uncompressed) {
        return BodyError(absl::StrCat("LZF data is corrupt (decompressed ", written, " of ",
                                      uncompressed, " bytes)"));
    }
    // Step 3: field-by-field layout: all values of a field, then the next field.
    const auto [ox, oy, oz] = XyzOffsets(header, header.points);
    const auto [tx, ty, tz] = XyzTypes(header);
    const std::array<std::uint64_t, 3> sizes = {ScalarSize(tx), ScalarSize(ty), ScalarSize(tz)};
    PointSink sink(CloudFormat::kPcd, header.points);
    const char* base = fields.data();
    for (std::uint64_t i = 0; i < header.points; ++i) {
        sink.Add(LoadCoordinate(base + ox + i * sizes[0], tx, kSwap),
                 LoadCoordinate(base + oy + i * sizes[1], ty, kSwap),
                 LoadCoordinate(base + oz + i * sizes[2], tz, kSwap));
    }
    return std::move(sink).Finish();
}

}  // namespace soilvol::io::detail
