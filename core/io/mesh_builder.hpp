#pragma once

// Private to core/io: collects decoded vertices and faces into a DecodedMesh within a budget.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>

#include "absl/container/flat_hash_map.h"
#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/mesh_codec.hpp"

namespace soilvol::io::detail {

/// Receives every decoded vertex and face: keeps to the budget, refuses NaN/Inf coordinates,
/// fan-triangulates polygons and, in Finish, checks indices and drops degenerate triangles.
class MeshBuilder {
  public:
    MeshBuilder(MeshFormat format, const MeshBudget& budget);

    /// Reserves room for counts the caller has checked against the budget and the input.
    void Reserve(std::size_t vertices, std::size_t triangles);

    /// Appends vertex number vertex_count() + 1; a NaN/Inf coordinate or a spent vertex budget
    /// gets InvalidArgument.
    absl::Status AddVertex(float x, float y, float z);

    /// Starts the next polygon; its corners follow as 0-based vertex indices.
    void BeginFace();
    /// Adds a corner; from the third on each closes a triangle of the fan. A spent triangle
    /// budget gets InvalidArgument; indices are checked in Finish (they may point ahead).
    absl::Status AddCorner(std::uint64_t index);
    /// Ends the polygon; fewer than 3 corners get InvalidArgument.
    absl::Status EndFace();

    /// Appends an STL facet, its corners merged with earlier ones at exactly equal positions; a
    /// NaN/Inf coordinate or a spent budget gets InvalidArgument naming the facet.
    absl::Status AddFacet(const std::array<Eigen::Vector3f, 3>& corners);

    std::size_t vertex_count() const { return mesh_.vertices.size(); }

    /// The mesh without its degenerate triangles; an index out of range or no triangle left gets
    /// InvalidArgument.
    absl::StatusOr<DecodedMesh> Finish() &&;

  private:
    absl::Status AddTriangle(std::uint64_t a, std::uint64_t b, std::uint64_t c);
    absl::StatusOr<std::uint64_t> MergedVertex(const Eigen::Vector3f& corner);

    DecodedMesh mesh_;
    std::size_t max_vertices_;
    std::size_t max_triangles_;
    std::size_t faces_ = 0;  // polygons begun (or STL facets added)
    std::size_t corners_ = 0;
    std::uint64_t first_corner_ = 0;
    std::uint64_t last_corner_ = 0;
    std::uint64_t max_index_ = 0;     // largest index any corner used,
    std::size_t max_index_face_ = 0;  // first in this face (0: no corner yet)
    absl::flat_hash_map<std::array<float, 3>, std::uint64_t> merged_;  // STL: position -> index
};

}  // namespace soilvol::io::detail
