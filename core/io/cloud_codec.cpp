#include "core/io/cloud_codec.hpp"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/io/pcd_decoder.hpp"
#include "core/io/ply_decoder.hpp"
#include "core/io/point_sink.hpp"
#include "core/io/scalar_type.hpp"
#include "core/io/text_scanner.hpp"
#include "core/io/xyz_writer.hpp"

namespace soilvol::io {
namespace {

constexpr std::size_t kRawPointBytes = 12;

bool LooksLikePly(std::string_view bytes) {
    return bytes.substr(0, 4) == "ply\n" || bytes.substr(0, 5) == "ply\r\n";
}

// "# .PCD" magic, or a VERSION/FIELDS line after leading comment and blank lines.
bool LooksLikePcd(std::string_view bytes) {
    if (bytes.substr(0, 6) == "# .PCD") return true;
    detail::LineReader lines(bytes, detail::kMaxHeaderBytes);
    std::string_view line;
    while (lines.NextNonBlank(&line)) {
        detail::TokenReader tokens(line);
        std::string_view keyword;
        tokens.Next(&keyword);
        if (keyword[0] == '#') continue;
        return keyword == "VERSION" || keyword == "FIELDS";
    }
    return false;
}

absl::StatusOr<DecodedCloud> DecodeRaw(std::string_view bytes) {
    if (bytes.size() % kRawPointBytes != 0) {
        return absl::InvalidArgumentError(absl::StrCat(
            "raw xyz: size ", bytes.size(), " bytes is not a multiple of 12 (float32 x, y, z)"));
    }
    const std::size_t count = bytes.size() / kRawPointBytes;
    if (count > detail::kMaxPoints) {
        return absl::InvalidArgumentError(absl::StrCat("raw xyz: ", count,
                                                       " points is more than the ",
                                                       detail::kMaxPoints, " a scan may hold"));
    }
    constexpr bool kSwap = !detail::kHostIsLittleEndian;
    constexpr auto kF32 = detail::ScalarType::kFloat32;
    detail::PointSink sink(CloudFormat::kRawXyzF32, count);
    for (std::size_t i = 0; i < count; ++i) {
        const char* p = bytes.data() + i * kRawPointBytes;
        sink.Add(detail::LoadCoordinate(p, kF32, kSwap), detail::LoadCoordinate(p + 4, kF32, kSwap),
                 detail::LoadCoordinate(p + 8, kF32, kSwap));
    }
    return std::move(sink).Finish();
}

}  // namespace

absl::StatusOr<DecodedCloud> DecodeCloud(std::string_view bytes, bool allow_raw) {
    if (bytes.empty()) return absl::InvalidArgumentError("cloud data is empty (0 bytes)");
    if (LooksLikePly(bytes)) return detail::DecodePly(bytes);
    if (LooksLikePcd(bytes)) return detail::DecodePcd(bytes);
    if (allow_raw) return DecodeRaw(bytes);
    return absl::InvalidArgumentError("unknown cloud format (expected PLY or PCD)");
}

std::string EncodeRawXyzF32(const Cloud& points) {
    std::string out;
    detail::AppendBinaryXyz(points, /*big_endian=*/false, &out);
    return out;
}

}  // namespace soilvol::io
