#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/depth/depth_scan.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// One sensor's part of a scan, decoded: its returns in its own frame (the sensor at the origin)
/// and its pose in the frame the scan's sensors share.
struct SensorPart {
    Cloud points;
    Pose sensor_pose = Pose::Identity();
    double decode_ms = 0.0;
    std::size_t dropped_nonfinite = 0;                   ///< cloud files
    std::optional<depth::DepthScanCounts> depth_counts;  ///< depth images
    std::size_t depth_points = 0;                        ///< returns of depth images
};

/// A cloud file (`field` names it in errors): a PCD's VIEWPOINT or `cloud.sensor_pose` (which
/// wins) places the sensor; the points are mapped into its frame.
absl::StatusOr<SensorPart> DecodeCloudPart(const v1::CloudScan& cloud, const std::string& field);

/// A depth image back-projected in its camera's frame; `depth.sensor_pose` places the camera.
absl::StatusOr<SensorPart> DecodeDepthPart(const v1::DepthScan& depth, const std::string& field);

/// The most sensors one scan may hold.
inline constexpr int kMaxSensorsPerScan = 8;

/// The other sensors of `scan` (Scan.additional_sensors) in the first sensor's frame, placed by
/// their poses against `first_pose` (the first sensor's pose in the shared frame); each part's
/// decode time and counts are added to `first`. InvalidArgument naming the field for more than
/// kMaxSensorsPerScan sensors, a part with no source, or a bad file or pose.
absl::StatusOr<std::vector<SensorCloud>> DecodeAdditionalSensors(const v1::Scan& scan,
                                                                 SensorPart& first);

}  // namespace soilvol::server
