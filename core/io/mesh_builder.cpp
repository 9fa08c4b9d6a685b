#include "core/io/mesh_builder.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"

namespace soilvol::io::detail {
namespace {

// Height of a triangle over its longest edge below which it counts as zero area.
constexpr double kMinHeightRatio = 1e-9;
constexpr std::size_t kMaxIndexedVertices = std::numeric_limits<int>::max();

// Index as the file counts: OBJ from 1, the others from 0.
std::uint64_t FileIndex(MeshFormat format, std::uint64_t index) {
    switch (format) {
        case MeshFormat::kObj:
            return index + 1;
        case MeshFormat::kStlBinary:
        case MeshFormat::kStlAscii:
        case MeshFormat::kPly:
            return index;
    }
    return index;
}

bool IsDegenerate(const Eigen::Vector3i& triangle, const std::vector<Eigen::Vector3d>& vertices) {
    const int a = triangle[0], b = triangle[1], c = triangle[2];
    if (a == b || b == c || a == c) return true;
    const Eigen::Vector3d ab = vertices[b] - vertices[a];
    const Eigen::Vector3d ac = vertices[c] - vertices[a];
    const Eigen::Vector3d bc = vertices[c] - vertices[b];
    const double longest_sq = std::max({ab.squaredNorm(), ac.squaredNorm(), bc.squaredNorm()});
    // |ab x ac| = longest edge * height.
    return ab.cross(ac).norm() <= kMinHeightRatio * longest_sq;
}

}  // namespace

MeshBuilder::MeshBuilder(MeshFormat format, const MeshBudget& budget)
    : max_vertices_(std::min(budget.max_vertices, kMaxIndexedVertices)),
      max_triangles_(budget.max_triangles) {
    mesh_.format = format;
}

void MeshBuilder::Reserve(std::size_t vertices, std::size_t triangles) {
    mesh_.vertices.reserve(std::min(vertices, max_vertices_));
    mesh_.triangles.reserve(std::min(triangles, max_triangles_));
}

absl::Status MeshBuilder::AddVertex(float x, float y, float z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
        return absl::InvalidArgumentError(
            absl::StrCat("vertex ", mesh_.vertices.size() + 1, " has a NaN/Inf coordinate"));
    }
    if (mesh_.vertices.size() >= max_vertices_) {
        return absl::InvalidArgumentError(
            absl::StrCat("mesh has more than the budget of ", max_vertices_, " vertices"));
    }
    mesh_.vertices.emplace_back(x, y, z);
    return absl::OkStatus();
}

void MeshBuilder::BeginFace() {
    ++faces_;
    corners_ = 0;
}

absl::Status MeshBuilder::AddCorner(std::uint64_t index) {
    if (max_index_face_ == 0 || index > max_index_) {
        max_index_ = index;
        max_index_face_ = faces_;
    }
    if (corners_ == 0) first_corner_ = index;
    if (corners_ >= 2) {
        SOILVOL_RETURN_IF_ERROR(AddTriangle(first_corner_, last_corner_, index));
    }
    ++corners_;
    last_corner_ = index;
    return absl::OkStatus();
}

absl::Status MeshBuilder::EndFace() {
    if (corners_ >= 3) return absl::OkStatus();
    return absl::InvalidArgumentError(
        absl::StrCat("face ", faces_, " has ", corners_, " corners; a face needs at least 3"));
}

absl::Status MeshBuilder::AddFacet(const std::array<Eigen::Vector3f, 3>& corners) {
    ++faces_;
    for (const Eigen::Vector3f& corner : corners) {
        if (!corner.allFinite()) {
            return absl::InvalidArgumentError(
                absl::StrCat("facet ", faces_, " has a NaN/Inf coordinate"));
        }
    }
    std::array<std::uint64_t, 3> index{};
    for (std::size_t k = 0; k < 3; ++k) {
        SOILVOL_ASSIGN_OR_RETURN(index[k], MergedVertex(corners[k]));
    }
    return AddTriangle(index[0], index[1], index[2]);
}

absl::StatusOr<DecodedMesh> MeshBuilder::Finish() && {
    const std::size_t vertex_total = mesh_.vertices.size();
    if (max_index_face_ > 0 && max_index_ >= vertex_total) {
        return absl::InvalidArgumentError(absl::StrCat(
            "face ", max_index_face_, " refers to vertex ", FileIndex(mesh_.format, max_index_),
            " but the mesh has ", vertex_total, " vertices"));
    }
    std::vector<Eigen::Vector3i>& triangles = mesh_.triangles;
    const auto degenerate = [this](const Eigen::Vector3i& t) {
        return IsDegenerate(t, mesh_.vertices);
    };
    const auto kept = std::remove_if(triangles.begin(), triangles.end(), degenerate);
    mesh_.dropped_degenerate = static_cast<std::size_t>(triangles.end() - kept);
    triangles.erase(kept, triangles.end());
    if (!triangles.empty()) return std::move(mesh_);
    if (mesh_.dropped_degenerate == 0) return absl::InvalidArgumentError("mesh has no triangles");
    return absl::InvalidArgumentError(absl::StrCat("mesh has no valid triangle (all ",
                                                   mesh_.dropped_degenerate, " are degenerate)"));
}

absl::Status MeshBuilder::AddTriangle(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    if (mesh_.triangles.size() >= max_triangles_) {
        return absl::InvalidArgumentError(
            absl::StrCat("mesh has more than the budget of ", max_triangles_, " triangles"));
    }
    // An index beyond int is beyond every vertex count: Finish refuses it through max_index_.
    const auto narrow = [](std::uint64_t index) {
        return static_cast<int>(std::min<std::uint64_t>(index, kMaxIndexedVertices));
    };
    mesh_.triangles.emplace_back(narrow(a), narrow(b), narrow(c));
    return absl::OkStatus();
}

absl::StatusOr<std::uint64_t> MeshBuilder::MergedVertex(const Eigen::Vector3f& corner) {
    // + 0.0f turns -0 into +0, so both merge.
    const std::array<float, 3> key = {corner.x() + 0.0f, corner.y() + 0.0f, corner.z() + 0.0f};
    const auto found = merged_.find(key);
    if (found != merged_.end()) return found->second;
    if (mesh_.vertices.size() >= max_vertices_) {
        return absl::InvalidArgumentError(absl::StrCat(
            "facet ", faces_, ": mesh has more than the budget of ", max_vertices_, " vertices"));
    }
    const std::uint64_t index = mesh_.vertices.size();
    mesh_.vertices.push_back(corner.cast<double>());
    merged_.emplace(key, index);
    return index;
}

}  // namespace soilvol::io::detail
