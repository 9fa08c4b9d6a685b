#pragma once

#include <string>

#include "absl/status/status.h"
#include "client/demo_scene.hpp"

namespace soilvol::client {

/// Writes `scan` into `dir` (created if missing) as <stem>.ply, or <stem>-left.png and
/// <stem>-right.png, and its opening corners as <stem>-corners.txt in the form --corners or
/// --pixel-corners takes; for a cloud scan also the container's pose as <stem>-pose.txt in the
/// form --container-pose takes. Internal naming the file when one cannot be written.
absl::Status SaveDemoScan(const std::string& dir, const std::string& stem, const DemoScan& scan);

/// Writes `mesh` as <dir>/mesh.stl, its opening corners as <dir>/mesh-corners.txt (the form
/// --mesh-corners takes), and as <dir>/mesh.json the rest of a mesh registration without a
/// scan in proto3 JSON (MeshScan without data: corners, `pose` - the mesh frame in the
/// sensor's - and `range_noise_m`), for curl.
absl::Status SaveDemoMesh(const std::string& dir, const DemoMesh& mesh, const v1::Pose& pose,
                          double range_noise_m);

/// Writes `parameters` as <dir>/parameters.json (proto3 JSON, for calibrate --parameters).
absl::Status SaveDemoParameters(const std::string& dir, const v1::StereoParameters& parameters);

}  // namespace soilvol::client
