#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/mesh_decoder.hpp"
#include "core/io/ply_decoder.hpp"
#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {
namespace {

absl::Status MeshError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("PLY mesh: ", what));
}

absl::Status CheckBudget(const PlyElement& element, std::size_t limit, const char* unit) {
    if (element.count <= limit) return absl::OkStatus();
    return MeshError(absl::StrCat(element.name, " count ", element.count,
                                  " is more than the budget of ", limit, " ", unit));
}

// Calls visit(entry, offsets, i) for each binary entry of `element` at the front of `data`;
// returns the bytes walked.
template <typename Visit>
absl::StatusOr<std::size_t> WalkEntries(const PlyElement& element, std::string_view data, bool swap,
                                        const Visit& visit) {
    std::vector<std::size_t> offsets(element.properties.size());
    std::size_t pos = 0;
    for (std::uint64_t i = 0; i < element.count; ++i) {
        SOILVOL_ASSIGN_OR_RETURN(const std::size_t size,
                                 BinaryEntrySize(element, data.substr(pos), swap, &offsets));
        SOILVOL_RETURN_IF_ERROR(visit(data.data() + pos, offsets, i));
        pos += size;
    }
    return pos;
}

// The index list of one face entry; BinaryEntrySize has checked that it is all there.
absl::Status ReadFace(const PlyProperty& list, const char* p, bool swap, std::uint64_t number,
                      MeshBuilder* mesh) {
    const std::uint64_t corners = LoadCount(p, *list.list_count_type, swap).value_or(0);
    p += ScalarSize(*list.list_count_type);
    mesh->BeginFace();
    for (std::uint64_t j = 0; j < corners; ++j, p += ScalarSize(list.type)) {
        const std::optional<std::uint64_t> index = LoadCount(p, list.type, swap);
        if (!index) return MeshError(absl::StrCat("face ", number, " has a negative index"));
        SOILVOL_RETURN_IF_ERROR(mesh->AddCorner(*index));
    }
    return mesh->EndFace();
}

}  // namespace

absl::StatusOr<DecodedMesh> DecodePlyMesh(std::string_view bytes, const MeshBudget& budget) {
    SOILVOL_ASSIGN_OR_RETURN(const PlyHeader header, ParsePlyHeader(bytes, PlyContent::kMesh));
    const PlyElement& vertex = header.elements[header.vertex_element];
    const PlyElement& face = header.elements[header.face_element];
    SOILVOL_RETURN_IF_ERROR(CheckBudget(vertex, budget.max_vertices, "vertices"));
    // Every face is at least one triangle.
    SOILVOL_RETURN_IF_ERROR(CheckBudget(face, budget.max_triangles, "triangles"));
    const std::string_view body = bytes.substr(header.body_offset);
    const bool ascii = header.format == PlyFormat::kAscii;
    // Both must fit in the body before room is reserved for them.
    for (const PlyElement* element : {&vertex, &face}) {
        SOILVOL_RETURN_IF_ERROR(ascii ? CheckAsciiFits(*element, body.size())
                                      : CheckBinaryFits(*element, LayoutOf(*element), body.size()));
    }
    MeshBuilder mesh(MeshFormat::kPly, budget);
    mesh.Reserve(vertex.count, face.count);
    SOILVOL_RETURN_IF_ERROR(ascii ? DecodePlyMeshAsciiBody(header, body, &mesh)
                                  : DecodePlyMeshBinaryBody(header, body, &mesh));
    return std::move(mesh).Finish();
}

absl::Status DecodePlyMeshBinaryBody(const PlyHeader& header, std::string_view body,
                                     MeshBuilder* mesh) {
    const bool file_little_endian = header.format == PlyFormat::kBinaryLittleEndian;
    const bool swap = file_little_endian != kHostIsLittleEndian;
    const PlyElement& vertex = header.elements[header.vertex_element];
    const auto read_vertex = [&](const char* entry, const std::vector<std::size_t>& offsets,
                                 std::uint64_t) {
        std::array<float, 3> xyz{};
        for (std::size_t axis = 0; axis < 3; ++axis) {
            const std::size_t property = header.xyz_property[axis];
            xyz[axis] =
                LoadCoordinate(entry + offsets[property], vertex.properties[property].type, swap);
        }
        return mesh->AddVertex(xyz[0], xyz[1], xyz[2]);
    };
    const std::size_t k = header.face_indices_property;
    const PlyProperty& list = header.elements[header.face_element].properties[k];
    const auto read_face = [&](const char* entry, const std::vector<std::size_t>& offsets,
                               std::uint64_t i) {
        return ReadFace(list, entry + offsets[k], swap, i + 1, mesh);
    };
    // Elements before the last of vertex and face are walked or skipped; later ones ignored.
    const std::size_t last = std::max(header.vertex_element, header.face_element);
    for (std::size_t e = 0; e <= last; ++e) {
        const PlyElement& element = header.elements[e];
        absl::StatusOr<std::size_t> size;
        if (e == header.vertex_element) {
            size = WalkEntries(element, body, swap, read_vertex);
        } else if (e == header.face_element) {
            size = WalkEntries(element, body, swap, read_face);
        } else {
            size = SkipBinaryElement(element, body, swap);
        }
        if (!size.ok()) return size.status();
        body.remove_prefix(*size);
    }
    return absl::OkStatus();
}

}  // namespace soilvol::io::detail
