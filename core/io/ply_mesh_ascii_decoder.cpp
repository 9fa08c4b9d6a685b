#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/mesh_decoder.hpp"
#include "core/io/ply_decoder.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

absl::Status FaceError(std::uint64_t number, absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PLY ascii: face ", number, " ", what));
}

// One face line: a token per scalar property, a count and its items per list property; the
// list `indices` holds the corners.
absl::Status ParseFaceLine(const PlyElement& face, std::size_t indices, std::string_view line,
                           std::uint64_t number, MeshBuilder* mesh) {
    TokenReader tokens(line);
    std::string_view token;
    for (std::size_t k = 0; k < face.properties.size(); ++k) {
        if (!tokens.Next(&token)) return FaceError(number, "has too few values");
        if (!face.properties[k].list_count_type) continue;
        std::uint64_t items = 0;
        if (!ParseUint64(token, &items)) {
            return FaceError(number,
                             absl::StrCat("list count '", Printable(token), "' is not a count"));
        }
        if (k == indices) mesh->BeginFace();
        for (std::uint64_t j = 0; j < items; ++j) {
            if (!tokens.Next(&token)) return FaceError(number, "has too few values");
            if (k != indices) continue;
            std::uint64_t index = 0;
            if (!ParseUint64(token, &index)) {
                return FaceError(number,
                                 absl::StrCat("'", Printable(token), "' is not a vertex index"));
            }
            SOILVOL_RETURN_IF_ERROR(mesh->AddCorner(index));
        }
        if (k == indices) SOILVOL_RETURN_IF_ERROR(mesh->EndFace());
    }
    return absl::OkStatus();
}

}  // namespace

absl::Status DecodePlyMeshAsciiBody(const PlyHeader& header, std::string_view body,
                                    MeshBuilder* mesh) {
    const PlyElement& vertex = header.elements[header.vertex_element];
    std::vector<int> axis_of(vertex.properties.size(), -1);
    for (std::size_t axis = 0; axis < 3; ++axis) {
        axis_of[header.xyz_property[axis]] = static_cast<int>(axis);
    }
    LineReader lines(body);
    std::string_view line;
    std::array<float, 3> xyz{};
    // Elements before the last of vertex and face are read or skipped; later lines ignored.
    const std::size_t last = std::max(header.vertex_element, header.face_element);
    for (std::size_t e = 0; e <= last; ++e) {
        const PlyElement& element = header.elements[e];
        if (e != header.vertex_element && e != header.face_element) {
            SOILVOL_RETURN_IF_ERROR(SkipAsciiElement(element, &lines));
            continue;
        }
        for (std::uint64_t i = 0; i < element.count; ++i) {
            if (!lines.NextNonBlank(&line)) return AsciiEndsEarly(element, i);
            if (e == header.face_element) {
                SOILVOL_RETURN_IF_ERROR(
                    ParseFaceLine(element, header.face_indices_property, line, i + 1, mesh));
                continue;
            }
            SOILVOL_RETURN_IF_ERROR(ParseAsciiVertexLine(vertex, axis_of, line, i, &xyz));
            SOILVOL_RETURN_IF_ERROR(mesh->AddVertex(xyz[0], xyz[1], xyz[2]));
        }
    }
    return absl::OkStatus();
}

}  // namespace soilvol::io::detail
