#include "server/handlers/mesh_request.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

// Binary PLY is the densest mesh format: a triangle is a count byte and three int32 indices,
// a vertex three float32 coordinates.
constexpr std::size_t kPlyTriangleBytes = 13;
constexpr std::size_t kPlyVertexBytes = 12;

absl::Status Invalid(const std::string& field, const std::string& problem) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

absl::StatusOr<Corners> ToMeshCorners(const v1::MeshScan& proto) {
    if (proto.corners_size() != 4) {
        return Invalid("mesh.corners",
                       absl::StrCat("needs the opening's 4 corners in the mesh's frame, got ",
                                    proto.corners_size()));
    }
    Corners corners;
    for (int i = 0; i < 4; ++i) {
        const v1::Point3& p = proto.corners(i);
        corners[i] = {p.x(), p.y(), p.z()};
        if (!corners[i].allFinite()) {
            return Invalid(absl::StrCat("mesh.corners[", i, "]"), "is not finite");
        }
    }
    return corners;
}

/// The placement a mesh alone needs, refused beside a scan (which places the container).
absl::Status CheckPlacement(const v1::MeshScan& proto, bool with_scan) {
    if (with_scan) {
        if (proto.has_container_pose()) {
            return Invalid("mesh.container_pose",
                           "only without a scan: the scan places the container");
        }
        if (proto.range_noise_m() != 0.0) {
            return Invalid("mesh.range_noise_m", "only without a scan: the scan has its own noise");
        }
        return absl::OkStatus();
    }
    if (!proto.has_container_pose()) {
        return Invalid("mesh.container_pose",
                       "is required without a scan: the mesh frame in the sensor's frame");
    }
    if (proto.range_noise_m() == 0.0) {
        return Invalid("mesh.range_noise_m",
                       "is required without a scan: the sensor's range noise (1 sigma) [m]");
    }
    return absl::OkStatus();
}

}  // namespace

io::MeshBudget MeshBudgetFor(std::size_t max_message_bytes) {
    io::MeshBudget budget;
    budget.max_triangles = std::min(budget.max_triangles, max_message_bytes / kPlyTriangleBytes);
    budget.max_vertices = std::min(budget.max_vertices, max_message_bytes / kPlyVertexBytes);
    return budget;
}

absl::StatusOr<MeshRequest> ToMeshRequest(const v1::MeshScan& proto, bool with_scan,
                                          const io::MeshBudget& budget) {
    MeshRequest out;
    SOILVOL_ASSIGN_OR_RETURN(out.input.corners, ToMeshCorners(proto));
    SOILVOL_RETURN_IF_ERROR(CheckPlacement(proto, with_scan));
    if (!with_scan) {
        SOILVOL_ASSIGN_OR_RETURN(out.T_scan_mesh,
                                 ToPose(proto.container_pose(), "mesh.container_pose"));
        out.range_noise_m = proto.range_noise_m();
    }
    if (proto.data().empty()) return Invalid("mesh.data", "is empty: give an STL, OBJ or PLY file");
    Timer timer;
    absl::StatusOr<io::DecodedMesh> mesh = io::DecodeMesh(proto.data(), budget);
    if (!mesh.ok()) return Annotate(mesh.status(), "mesh.data");
    out.decode_ms = timer.Lap();
    out.input.mesh.vertices = std::move(mesh->vertices);
    out.input.mesh.triangles = std::move(mesh->triangles);
    return out;
}

absl::Status MeshStatus(const absl::Status& status, bool with_scan) {
    if (!absl::IsInvalidArgument(status)) return status;
    static constexpr std::array<std::pair<const char*, const char*>, 3> kRenamed = {{
        {"range_noise_m", "mesh.range_noise_m"},
        {"container_pose", "mesh.container_pose"},
        {"mesh.opening", "mesh.corners"},
    }};
    const std::string field = FieldOf(status.message());
    for (const auto& [core_name, api_name] : kRenamed) {
        if (field == core_name) {
            return absl::InvalidArgumentError(
                absl::StrCat(api_name, status.message().substr(field.size())));
        }
    }
    if (field.empty() && !with_scan) return Annotate(status, "mesh.corners");
    return status;
}

}  // namespace soilvol::server
