#include <algorithm>
#include <array>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/ply_decoder.hpp"
#include "core/io/point_sink.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

absl::Status AsciiError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PLY ascii: ", what));
}

}  // namespace

// Each entry is a line with a token per property, so it takes at least 2 bytes per property.
absl::Status CheckAsciiFits(const PlyElement& element, std::size_t available) {
    const std::uint64_t min_line_bytes = 2 * std::max<std::uint64_t>(element.properties.size(), 1);
    if (element.count > (static_cast<std::uint64_t>(available) + 1) / min_line_bytes) {
        return AsciiError(absl::StrCat(element.name, " count ", element.count,
                                       " cannot fit in the ", available, " bytes that follow"));
    }
    return absl::OkStatus();
}

absl::Status AsciiEndsEarly(const PlyElement& element, std::uint64_t read) {
    return AsciiError(absl::StrCat("expected ", element.count, " ", element.name,
                                   " lines but the data ends after ", read));
}

// An element without properties has no lines; one with properties has one line per entry.
absl::Status SkipAsciiElement(const PlyElement& element, LineReader* lines) {
    if (element.properties.empty()) return absl::OkStatus();
    SOILVOL_RETURN_IF_ERROR(CheckAsciiFits(element, lines->remaining()));
    std::string_view line;
    for (std::uint64_t i = 0; i < element.count; ++i) {
        if (!lines->NextNonBlank(&line)) return AsciiEndsEarly(element, i);
    }
    return absl::OkStatus();
}

absl::Status ParseAsciiVertexLine(const PlyElement& vertex, const std::vector<int>& axis_of,
                                  std::string_view line, std::uint64_t index,
                                  std::array<float, 3>* xyz) {
    const auto too_few = [index] {
        return AsciiError(absl::StrCat("vertex ", index + 1, " has too few values"));
    };
    TokenReader tokens(line);
    std::string_view token;
    for (std::size_t k = 0; k < vertex.properties.size(); ++k) {
        const PlyProperty& property = vertex.properties[k];
        if (!tokens.Next(&token)) return too_few();
        if (property.list_count_type) {
            std::uint64_t items = 0;
            if (!ParseUint64(token, &items)) {
                return AsciiError(absl::StrCat("vertex ", index + 1, ": list count '",
                                               Printable(token), "' is not a count"));
            }
            for (std::uint64_t j = 0; j < items; ++j) {
                if (!tokens.Next(&token)) return too_few();
            }
            continue;
        }
        if (axis_of[k] < 0) continue;
        const bool as_double = property.type == ScalarType::kFloat64;
        if (!ParseCoordinate(token, as_double, &(*xyz)[static_cast<std::size_t>(axis_of[k])])) {
            return AsciiError(absl::StrCat("vertex ", index + 1, ": '", Printable(token),
                                           "' is not a number (property '", property.name, "')"));
        }
    }
    return absl::OkStatus();
}

namespace {

absl::StatusOr<DecodedCloud> DecodeVertices(const PlyHeader& header, LineReader* lines) {
    const PlyElement& vertex = header.elements[header.vertex_element];
    SOILVOL_RETURN_IF_ERROR(CheckAsciiFits(vertex, lines->remaining()));
    std::vector<int> axis_of(vertex.properties.size(), -1);
    for (std::size_t axis = 0; axis < 3; ++axis) {
        axis_of[header.xyz_property[axis]] = static_cast<int>(axis);
    }
    PointSink sink(CloudFormat::kPly, vertex.count);
    std::string_view line;
    std::array<float, 3> xyz{};
    for (std::uint64_t i = 0; i < vertex.count; ++i) {
        if (!lines->NextNonBlank(&line)) return AsciiEndsEarly(vertex, i);
        SOILVOL_RETURN_IF_ERROR(ParseAsciiVertexLine(vertex, axis_of, line, i, &xyz));
        sink.Add(xyz[0], xyz[1], xyz[2]);
    }
    return std::move(sink).Finish();
}

}  // namespace

absl::StatusOr<DecodedCloud> DecodePlyAsciiBody(const PlyHeader& header, std::string_view body) {
    LineReader lines(body);
    // Elements before the vertex element are skipped; lines after it are ignored.
    for (std::size_t e = 0; e < header.vertex_element; ++e) {
        SOILVOL_RETURN_IF_ERROR(SkipAsciiElement(header.elements[e], &lines));
    }
    return DecodeVertices(header, &lines);
}

}  // namespace soilvol::io::detail
