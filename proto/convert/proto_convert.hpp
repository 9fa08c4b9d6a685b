#pragma once

#include <string>

#include "absl/status/statusor.h"
#include "core/common/camera.hpp"
#include "core/common/types.hpp"
#include "core/depth/depth_scan.hpp"
#include "core/model/container_model.hpp"
#include "core/pipeline/stereo_estimator.hpp"
#include "core/stereo/calibration.hpp"
#include "core/volume/load_status.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// Proto -> core, with InvalidArgument naming the field (`field` is its path in the request,
/// e.g. "parameters.left.fx") for counts and values the core cannot take.
absl::StatusOr<StereoParameters> ToStereoParameters(const v1::StereoParameters& proto,
                                                    const std::string& field);
absl::StatusOr<stereo::ChessboardSpec> ToChessboardSpec(const v1::ChessboardCalibration& proto);
/// A depth scan's camera and filter options (enums checked here; the numbers are checked
/// against the image by core's ValidateDepthCamera).
struct DepthScanOptions {
    depth::DepthCamera camera;
    depth::DepthScanConfig config;
};
absl::StatusOr<DepthScanOptions> ToDepthScanOptions(const v1::DepthScan& proto,
                                                    const std::string& field);
/// Exactly four 3D corners or four pixel corners; pixel corners only when `stereo_scan`.
absl::StatusOr<pipeline::OpeningMarks> ToOpeningMarks(const v1::Opening& proto, bool stereo_scan);

/// A stored calibration's rig, rebuilt from its message: the parameters rectified again
/// (stereo::CalibrationFromParameters), the chessboard figures copied. InvalidArgument naming
/// the field for parameters the core refuses.
absl::StatusOr<stereo::StereoCalibration> ToStereoCalibration(const v1::Calibration& proto);

/// A container's material and load targets (unset fields at their defaults), checked by core's
/// rules: InvalidArgument naming the field ("material.density_kg_m3").
struct LoadRules {
    volume::Material material;
    volume::LoadTargets targets;
};
absl::StatusOr<LoadRules> ToLoadRules(const v1::Material& material, const v1::LoadTargets& targets);

/// The time now to the microsecond (Debian's protobuf TimeUtil::GetCurrentTime() has whole
/// seconds only, which orders nothing within a second).
google::protobuf::Timestamp NowTimestamp();
/// NowTimestamp in microseconds since the epoch.
std::int64_t NowMicros();
/// Microseconds since the epoch of a request's time, refusing one outside RFC 3339's years
/// 1..9999 or with nanos out of range (InvalidArgument naming `field`).
absl::StatusOr<std::int64_t> TimestampMicros(const google::protobuf::Timestamp& time,
                                             const char* field);
/// A List's optional [start_time, end_time) (null: unset) in microseconds into `start_us` and
/// `end_us`, which keep their values for an unset end; InvalidArgument naming the field, and for
/// an end_time not after start_time.
absl::Status TimeRangeMicros(const google::protobuf::Timestamp* start,
                             const google::protobuf::Timestamp* end, std::int64_t* start_us,
                             std::int64_t* end_us);

/// The estimate's heightmap as a PNG colour map with its load centre (volume::RenderHeightmap),
/// each cell `cell_px` pixels. FailedPrecondition when the estimate holds no heightmap,
/// DataLoss when it does not unpack.
absl::StatusOr<std::string> HeightmapPng(const v1::EstimateVolumeResponse& estimate, int cell_px);

/// Core -> proto.
void ToProto(const depth::DepthScanCounts& counts, std::size_t points, v1::DepthPixels* proto);
void ToProto(const StereoParameters& parameters, v1::StereoParameters* proto);
void ToProto(const stereo::StereoCalibration& calibration, v1::Calibration* proto);
/// The model's figures; ids, provenance and time are the caller's.
void ToProto(const model::ContainerModel& model, v1::Container* proto);
/// A pose from the API: finite values and a unit quaternion (within 1e-3; all zero is the
/// identity), else InvalidArgument naming `field`.
absl::StatusOr<Pose> ToPose(const v1::Pose& proto, const std::string& field);
void ToProto(const Pose& pose, v1::Pose* proto);
/// The per-cell soil heights as a packed float32 heightmap.
void ToProto(const volume::VolumeResult& volume, v1::Heightmap* proto);
/// The estimate's figures into `proto` (stereo timings separately, by the caller).
void ToProto(const pipeline::VolumeEstimate& estimate, v1::EstimateVolumeResponse* proto);
/// The assessment's fields (a response's mass_kg is the caller's to set: it is not in it).
void ToProto(const volume::LoadAssessment& load, v1::LoadAssessment* out);

}  // namespace soilvol::server
