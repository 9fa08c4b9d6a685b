#include <array>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/pcd_decoder.hpp"
#include "core/io/point_sink.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

absl::Status AsciiError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PCD ascii: ", what));
}

// Token positions of x, y and z on a line, and the number of tokens per line.
struct LineLayout {
    std::array<std::uint64_t, 3> xyz_token{};
    std::uint64_t tokens = 0;
};

LineLayout LayoutOf(const PcdHeader& header) {
    LineLayout layout;
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
        for (std::size_t axis = 0; axis < 3; ++axis) {
            if (header.xyz_field[axis] == f) layout.xyz_token[axis] = layout.tokens;
        }
        layout.tokens += header.fields[f].count;  // <= point size, so no overflow
    }
    return layout;
}

absl::Status ParsePointLine(const PcdHeader& header, const LineLayout& layout,
                            std::string_view line, std::uint64_t index, std::array<float, 3>* xyz) {
    TokenReader tokens(line);
    std::string_view token;
    for (std::uint64_t t = 0; t < layout.tokens; ++t) {
        if (!tokens.Next(&token)) {
            return AsciiError(absl::StrCat("point ", index + 1, " has too few values (expected ",
                                           layout.tokens, ")"));
        }
        for (std::size_t axis = 0; axis < 3; ++axis) {
            if (layout.xyz_token[axis] != t) continue;
            const bool as_double = header.fields[header.xyz_field[axis]].size == 8;
            if (!ParseCoordinate(token, as_double, &(*xyz)[axis])) {
                return AsciiError(absl::StrCat("point ", index + 1, ": '", Printable(token),
                                               "' is not a number"));
            }
        }
    }
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<DecodedCloud> DecodePcdAsciiBody(const PcdHeader& header, std::string_view body) {
    const LineLayout layout = LayoutOf(header);
    // Each point is a line with a token per value: at least 2 bytes per value.
    std::uint64_t min_line_bytes = 0;
    if (!CheckedMul(layout.tokens, 2, &min_line_bytes) ||
        header.points > (static_cast<std::uint64_t>(body.size()) + 1) / min_line_bytes) {
        return AsciiError(absl::StrCat("POINTS ", header.points, " cannot fit in the ", body.size(),
                                       " bytes that follow"));
    }
    PointSink sink(CloudFormat::kPcd, header.points);
    LineReader lines(body);
    std::string_view line;
    std::array<float, 3> xyz{};
    for (std::uint64_t i = 0; i < header.points; ++i) {
        if (!lines.NextNonBlank(&line)) {
            return AsciiError(
                absl::StrCat("expected ", header.points, " points but the data ends after ", i));
        }
        SOILVOL_RETURN_IF_ERROR(ParsePointLine(header, layout, line, i, &xyz));
        sink.Add(xyz[0], xyz[1], xyz[2]);
    }
    return std::move(sink).Finish();
}

}  // namespace soilvol::io::detail
