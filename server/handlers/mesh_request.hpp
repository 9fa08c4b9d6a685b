#pragma once

#include <cstddef>
#include <optional>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/io/mesh_codec.hpp"
#include "core/pipeline/registration.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// A registration's mesh (RegisterContainerRequest.mesh) in core's terms.
struct MeshRequest {
    pipeline::MeshInput input;        ///< the decoded mesh and its opening corners (mesh frame)
    std::optional<Pose> T_scan_mesh;  ///< without a scan: the mesh frame in the sensor's frame
    double range_noise_m = 0.0;       ///< without a scan: the sensor's range noise [m]
    double decode_ms = 0.0;
};

/// What one mesh may hold on a server whose messages are at most `max_message_bytes`: as many
/// triangles (vertices) as a binary PLY of that size holds at 13 (12) bytes each, at most
/// io::MeshBudget's defaults.
io::MeshBudget MeshBudgetFor(std::size_t max_message_bytes);

/// `proto` checked and decoded, every error InvalidArgument naming its field under "mesh.":
/// 4 finite corners; with a scan neither container_pose nor range_noise_m, without one both
/// (the pose as ToPose takes it; the noise's range is core's, see MeshStatus); data decoded by
/// io::DecodeMesh within `budget`.
absl::StatusOr<MeshRequest> ToMeshRequest(const v1::MeshScan& proto, bool with_scan,
                                          const io::MeshBudget& budget);

/// A status of pipeline::RegisterWithMesh with core's field names made the request's
/// (range_noise_m, container_pose and mesh.opening become mesh.range_noise_m,
/// mesh.container_pose and mesh.corners); without a scan, an InvalidArgument that names no
/// field is about the corners the mesh's opening was built from (mesh.corners).
absl::Status MeshStatus(const absl::Status& status, bool with_scan);

}  // namespace soilvol::server
