#pragma once

// Private to core/io: the mesh decoder of each format (see DecodeMesh for the contract).

#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/mesh_builder.hpp"
#include "core/io/mesh_codec.hpp"
#include "core/io/ply_header.hpp"

namespace soilvol::io::detail {

/// Binary STL: an 80-byte header, a little-endian uint32 count and 50 bytes per facet.
inline constexpr std::size_t kStlHeaderBytes = 84;
inline constexpr std::size_t kStlFacetBytes = 50;

/// True when `bytes` are exactly as long as the binary STL facet count they hold declares.
bool HasBinaryStlSize(std::string_view bytes);

/// Decodes a binary STL; a size other than the declared count's gets InvalidArgument.
absl::StatusOr<DecodedMesh> DecodeStlBinary(std::string_view bytes, const MeshBudget& budget);

/// True when `bytes` start with a "solid" line followed by "facet" or "endsolid".
bool LooksLikeAsciiStl(std::string_view bytes);

/// Decodes an ASCII STL (one or more solids).
absl::StatusOr<DecodedMesh> DecodeStlAscii(std::string_view bytes, const MeshBudget& budget);

/// True when a `v` line comes before any line that is neither an OBJ statement nor a comment.
bool LooksLikeObj(std::string_view bytes);

/// Decodes a Wavefront OBJ; only `v` and `f` lines are read.
absl::StatusOr<DecodedMesh> DecodeObj(std::string_view bytes, const MeshBudget& budget);

/// Decodes a PLY mesh; `bytes` start with the "ply" line.
absl::StatusOr<DecodedMesh> DecodePlyMesh(std::string_view bytes, const MeshBudget& budget);

/// Decodes the vertex and face elements of the ascii body that follows `header` into `mesh`.
absl::Status DecodePlyMeshAsciiBody(const PlyHeader& header, std::string_view body,
                                    MeshBuilder* mesh);

/// Decodes the vertex and face elements of the binary body that follows `header` into `mesh`.
absl::Status DecodePlyMeshBinaryBody(const PlyHeader& header, std::string_view body,
                                     MeshBuilder* mesh);

}  // namespace soilvol::io::detail
