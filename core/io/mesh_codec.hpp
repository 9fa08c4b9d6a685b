#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace soilvol::io {

enum class MeshFormat { kStlBinary, kStlAscii, kObj, kPly };

/// What one decoded mesh may hold. A file declaring more (a binary STL triangle count, a PLY
/// element count) is refused before anything is allocated; text formats are refused as soon as
/// they pass the limit.
struct MeshBudget {
    std::size_t max_triangles = 2'000'000;  ///< after fan triangulation, degenerate ones included
    std::size_t max_vertices = 2'000'000;   ///< never more than 2^31 - 1 (indices are int)
};

/// A triangle mesh decoded from untrusted bytes [m, as given].
struct DecodedMesh {
    /// Finite, read at float32 precision (as clouds are) [m, as given].
    std::vector<Eigen::Vector3d> vertices;
    /// Indices into vertices, counter-clockwise = outward as stored.
    std::vector<Eigen::Vector3i> triangles;
    /// Triangles with a repeated index or (near-)zero area (height below 1e-9 of the longest
    /// edge), left out.
    std::size_t dropped_degenerate = 0;
    MeshFormat format = MeshFormat::kStlBinary;
};

/// Decodes a triangle mesh: binary STL (80-byte header, count, 50-byte facets; its size must be
/// 84 + 50 * count), ASCII STL, Wavefront OBJ (`v` and `f` lines; 1-based or negative relative
/// indices, `v/vt/vn` corners; other statements ignored) or PLY with a `face` element holding a
/// `vertex_indices` list (ascii, binary_little_endian, binary_big_endian). The format is
/// detected from the content. Polygons are fan-triangulated; STL's per-facet corners are merged
/// where their positions are exactly equal, and its stored normals are ignored (the corner
/// order gives the orientation). Degenerate triangles are dropped and counted. Empty,
/// unrecognised, malformed or truncated input, a count beyond the budget or the bytes present,
/// an index out of range, a NaN/Inf coordinate (named by vertex or facet number) or a mesh
/// without a valid triangle gets InvalidArgument with a message naming the problem.
absl::StatusOr<DecodedMesh> DecodeMesh(std::string_view bytes, const MeshBudget& budget = {});

/// Encodes `mesh` as binary (or ASCII) STL: float32 coordinates, facet normals from the corner
/// order. Triangles with an index out of range are skipped.
std::string EncodeStl(const DecodedMesh& mesh, bool binary = true);

}  // namespace soilvol::io
