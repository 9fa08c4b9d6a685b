#include "server/handlers/sensor_part.hpp"

#include "absl/strings/str_cat.h"
#include "core/cloud/sensor_frame.hpp"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/io/cloud_codec.hpp"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

void AddCounts(const depth::DepthScanCounts& more, std::optional<depth::DepthScanCounts>& sum) {
    if (!sum) {
        sum = more;
        return;
    }
    sum->pixels += more.pixels;
    sum->no_return += more.no_return;
    sum->low_confidence += more.low_confidence;
    sum->out_of_range += more.out_of_range;
    sum->no_ray += more.no_ray;
    sum->flying += more.flying;
}

absl::StatusOr<SensorPart> DecodeSensorScan(const v1::SensorScan& part, const std::string& field) {
    switch (part.source_case()) {
        case v1::SensorScan::kCloud:
            return DecodeCloudPart(part.cloud(), absl::StrCat(field, ".cloud"));
        case v1::SensorScan::kDepth:
            return DecodeDepthPart(part.depth(), absl::StrCat(field, ".depth"));
        case v1::SensorScan::SOURCE_NOT_SET:
            break;
    }
    return absl::InvalidArgumentError(
        absl::StrCat(field,
                     ": is empty: give cloud {data, sensor_pose} or depth {depth, camera, "
                     "sensor_pose}"));
}

}  // namespace

absl::StatusOr<SensorPart> DecodeCloudPart(const v1::CloudScan& cloud, const std::string& field) {
    Timer timer;
    absl::StatusOr<io::DecodedCloud> decoded = io::DecodeCloud(cloud.data());
    if (!decoded.ok()) return Annotate(decoded.status(), absl::StrCat(field, ".data"));
    SensorPart out;
    out.sensor_pose = decoded->sensor_pose;  // the PCD's VIEWPOINT, if any
    if (cloud.has_sensor_pose()) {
        SOILVOL_ASSIGN_OR_RETURN(out.sensor_pose,
                                 ToPose(cloud.sensor_pose(), absl::StrCat(field, ".sensor_pose")));
    }
    out.points = cloud::InSensorFrame(std::move(decoded->points), out.sensor_pose);
    out.dropped_nonfinite = decoded->dropped_nonfinite;
    out.decode_ms = timer.Lap();
    return out;
}

absl::StatusOr<SensorPart> DecodeDepthPart(const v1::DepthScan& depth, const std::string& field) {
    Timer timer;
    SOILVOL_ASSIGN_OR_RETURN(const DepthScanOptions options, ToDepthScanOptions(depth, field));
    SensorPart out;
    if (depth.has_sensor_pose()) {
        SOILVOL_ASSIGN_OR_RETURN(out.sensor_pose,
                                 ToPose(depth.sensor_pose(), absl::StrCat(field, ".sensor_pose")));
    }
    absl::StatusOr<depth::DepthCloud> cloud = depth::DecodeDepthScan(
        depth.depth(), depth.confidence(), options.camera, options.config, field);
    if (!cloud.ok()) return cloud.status();
    out.points = std::move(cloud->points);
    out.depth_counts = cloud->counts;
    out.depth_points = out.points.size();
    out.decode_ms = timer.Lap();
    return out;
}

absl::StatusOr<std::vector<SensorCloud>> DecodeAdditionalSensors(const v1::Scan& scan,
                                                                 SensorPart& first) {
    if (scan.additional_sensors_size() >= kMaxSensorsPerScan) {
        return absl::InvalidArgumentError(absl::StrCat("scan.additional_sensors: at most ",
                                                       kMaxSensorsPerScan - 1, " (got ",
                                                       scan.additional_sensors_size(), ")"));
    }
    std::vector<SensorCloud> out;
    out.reserve(static_cast<std::size_t>(scan.additional_sensors_size()));
    const Pose T_scan_shared = first.sensor_pose.inverse();
    for (int i = 0; i < scan.additional_sensors_size(); ++i) {
        SOILVOL_ASSIGN_OR_RETURN(
            SensorPart part, DecodeSensorScan(scan.additional_sensors(i),
                                              absl::StrCat("scan.additional_sensors[", i, "]")));
        first.decode_ms += part.decode_ms;
        first.dropped_nonfinite += part.dropped_nonfinite;
        first.depth_points += part.depth_points;
        if (part.depth_counts) AddCounts(*part.depth_counts, first.depth_counts);
        out.push_back({std::move(part.points), T_scan_shared * part.sensor_pose});
    }
    return out;
}

}  // namespace soilvol::server
