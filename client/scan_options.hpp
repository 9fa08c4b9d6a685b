#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// A depth image's camera and filter options, as flags.
struct DepthOptions {
    std::string depth;
    std::string confidence;
    std::vector<double> intrinsics;  ///< fx, fy, cx, cy [px]
    std::string lens = "pinhole";
    std::vector<double> distortion;
    bool range = false;
    double unit_m = 0.0;
    double min_confidence = 0.0;
    double noise_m = 0.0;
    bool keep_flying = false;
};

/// Where a scan comes from: a point cloud file, a stereo pair with its calibration id, or a
/// depth image with its camera.
struct ScanOptions {
    std::string cloud;
    std::vector<double> sensor_pose;  ///< x, y, z [m], qw, qx, qy, qz: the sensor in the cloud
    std::string left;
    std::string right;
    std::string calibration;
    DepthOptions depth;
    /// The scan's other sensors' clouds (Scan.additional_sensors), and their sensors' poses in
    /// the shared frame: none, or 7 numbers per cloud in order.
    std::vector<std::string> more_clouds;
    std::vector<double> more_poses;
};

/// Adds --cloud [--sensor-pose] | (--left --right --calibration) | (--depth --intrinsics ...),
/// and [--also-cloud FILE [--also-sensor-pose ...]]... for a scan of several sensors, to
/// `command`;
/// `what` says which scan it is.
void AddScanOptions(CLI::App* command, ScanOptions* options, const std::string& what);

/// Reads the files into a Scan. InvalidArgument for a missing source, an incomplete stereo
/// triple, a depth image without its intrinsics, an unknown lens, an unreadable file (naming
/// it), or --also-sensor-pose not 7 numbers per --also-cloud.
absl::StatusOr<v1::Scan> BuildScan(const ScanOptions& options);

}  // namespace soilvol::client
