#pragma once

// Private to core/io: the PLY header and its parser.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {

enum class PlyFormat { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

/// What a file is read for: a cloud (vertices only) or a mesh (vertices and faces).
enum class PlyContent { kCloud, kMesh };

/// One `property` line: a scalar, or a list with its count type.
struct PlyProperty {
    std::string name;
    ScalarType type = ScalarType::kFloat32;     ///< value type (item type of a list)
    std::optional<ScalarType> list_count_type;  ///< set for list properties
};

/// One `element` line with its properties.
struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

/// A parsed PLY header with a vertex element holding float or double x, y and z.
struct PlyHeader {
    PlyFormat format = PlyFormat::kAscii;
    std::vector<PlyElement> elements;
    std::size_t vertex_element = 0;             ///< index into `elements`
    std::array<std::size_t, 3> xyz_property{};  ///< indices into the vertex properties
    std::size_t face_element = 0;               ///< index into `elements` (kMesh only)
    std::size_t face_indices_property = 0;      ///< the face's index list (kMesh only)
    std::size_t body_offset = 0;                ///< first byte after end_header's newline
};

/// Parses the header of `bytes`, which start with the "ply" line. A header that is malformed,
/// longer than kMaxHeaderBytes, without end_header or without a vertex element with float or
/// double x/y/z gets InvalidArgument. For kCloud, so does a vertex count of 0 or above
/// kMaxPoints; for kMesh, a header without one `face` element holding an integer list
/// `vertex_indices` (or `vertex_index`), and the counts are left to the caller's budget.
absl::StatusOr<PlyHeader> ParsePlyHeader(std::string_view bytes,
                                         PlyContent content = PlyContent::kCloud);

}  // namespace soilvol::io::detail
