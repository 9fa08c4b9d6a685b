#pragma once

#include <string>

#include "absl/status/status.h"
#include "client/demo_scene.hpp"

namespace soilvol::client {

/// Writes `scan` into `dir` (created if missing) as <stem>.ply, or <stem>-left.png and
/// <stem>-right.png, and its opening corners as <stem>-corners.txt in the form --corners or
/// --pixel-corners takes. Internal naming the file when one cannot be written.
absl::Status SaveDemoScan(const std::string& dir, const std::string& stem, const DemoScan& scan);

/// Writes `parameters` as <dir>/parameters.json (proto3 JSON, for calibrate --parameters).
absl::Status SaveDemoParameters(const std::string& dir, const v1::StereoParameters& parameters);

}  // namespace soilvol::client
