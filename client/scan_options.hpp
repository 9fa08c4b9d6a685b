#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "absl/status/statusor.h"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// Where a scan comes from: a point cloud file, or a stereo pair with its calibration id.
struct ScanOptions {
    std::string cloud;
    std::string left;
    std::string right;
    std::string calibration;
};

/// Adds --cloud | (--left --right --calibration) to `command`; `what` says which scan it is.
void AddScanOptions(CLI::App* command, ScanOptions* options, const std::string& what);

/// Reads the files into a Scan. InvalidArgument for a missing source, an incomplete stereo
/// triple or an unreadable file (naming it).
absl::StatusOr<v1::Scan> BuildScan(const ScanOptions& options);

}  // namespace soilvol::client
