#include "proto/convert/proto_convert.hpp"

#include <Eigen/Geometry>
#include <chrono>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/stereo/image_codec.hpp"
#include "core/volume/heightmap_image.hpp"
#include "core/volume/load_distribution.hpp"
#include "google/protobuf/util/time_util.h"

namespace soilvol::server {
namespace {

/// A sensor sees a container within this range; a pose beyond it is a unit mistake.
constexpr double kMaxCoordinateM = 1000.0;

absl::Status Invalid(const std::string& field, const std::string& problem) {
    return absl::InvalidArgumentError(absl::StrCat(field, ": ", problem));
}

CameraIntrinsics ToIntrinsics(const v1::CameraIntrinsics& proto) {
    CameraIntrinsics camera;
    camera.fx = proto.fx();
    camera.fy = proto.fy();
    camera.cx = proto.cx();
    camera.cy = proto.cy();
    camera.distortion.assign(proto.distortion().begin(), proto.distortion().end());
    return camera;
}

void ToProto(const CameraIntrinsics& camera, v1::CameraIntrinsics* proto) {
    proto->set_fx(camera.fx);
    proto->set_fy(camera.fy);
    proto->set_cx(camera.cx);
    proto->set_cy(camera.cy);
    for (const double k : camera.distortion) proto->add_distortion(k);
}

v1::Point3* AddPoint(const Eigen::Vector3d& p,
                     google::protobuf::RepeatedPtrField<v1::Point3>* out) {
    v1::Point3* point = out->Add();
    point->set_x(p.x());
    point->set_y(p.y());
    point->set_z(p.z());
    return point;
}

absl::StatusOr<depth::LensModel> ToLensModel(v1::LensModel lens, const std::string& field) {
    switch (lens) {
        case v1::LENS_MODEL_UNSPECIFIED:
        case v1::LENS_MODEL_PINHOLE:
            return depth::LensModel::kPinhole;
        case v1::LENS_MODEL_BROWN_CONRADY:
            return depth::LensModel::kBrownConrady;
        case v1::LENS_MODEL_KANNALA_BRANDT:
            return depth::LensModel::kKannalaBrandt;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat(field, ": unknown value ", static_cast<int>(lens)));
    }
}

absl::StatusOr<depth::DepthMeaning> ToDepthMeaning(v1::DepthMeaning meaning,
                                                   const std::string& field) {
    switch (meaning) {
        case v1::DEPTH_MEANING_UNSPECIFIED:
        case v1::DEPTH_MEANING_Z:
            return depth::DepthMeaning::kZ;
        case v1::DEPTH_MEANING_RANGE:
            return depth::DepthMeaning::kRange;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat(field, ": unknown value ", static_cast<int>(meaning)));
    }
}

}  // namespace

absl::StatusOr<DepthScanOptions> ToDepthScanOptions(const v1::DepthScan& proto,
                                                    const std::string& field) {
    DepthScanOptions out;
    const v1::DepthCamera& camera = proto.camera();
    out.camera.intrinsics = {camera.fx(),
                             camera.fy(),
                             camera.cx(),
                             camera.cy(),
                             {camera.distortion().begin(), camera.distortion().end()}};
    SOILVOL_ASSIGN_OR_RETURN(out.camera.lens, ToLensModel(camera.lens(), field + ".camera.lens"));
    SOILVOL_ASSIGN_OR_RETURN(out.camera.meaning,
                             ToDepthMeaning(camera.meaning(), field + ".camera.meaning"));
    out.camera.depth_unit_m = camera.depth_unit_m();
    if (!std::isfinite(proto.min_confidence())) {
        return absl::InvalidArgumentError(absl::StrCat(field, ".min_confidence: must be finite"));
    }
    out.config.min_confidence = proto.min_confidence();
    const double noise = proto.depth_noise_m();
    if (!std::isfinite(noise) || noise < 0.0 || noise > 1.0) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".depth_noise_m: must be in [0, 1] m (0: 0.002), got ", noise));
    }
    if (noise > 0.0) out.config.flying.noise_at_1m_m = noise;
    out.config.flying.enabled = !proto.keep_flying_pixels();
    return out;
}

void ToProto(const depth::DepthScanCounts& counts, std::size_t points, v1::DepthPixels* proto) {
    proto->set_pixels(static_cast<int64_t>(counts.pixels));
    proto->set_no_return(static_cast<int64_t>(counts.no_return));
    proto->set_low_confidence(static_cast<int64_t>(counts.low_confidence));
    proto->set_out_of_range(static_cast<int64_t>(counts.out_of_range));
    proto->set_no_ray(static_cast<int64_t>(counts.no_ray));
    proto->set_flying(static_cast<int64_t>(counts.flying));
    proto->set_points(static_cast<int64_t>(points));
}

absl::StatusOr<StereoParameters> ToStereoParameters(const v1::StereoParameters& proto,
                                                    const std::string& field) {
    if (!proto.has_left()) return Invalid(field + ".left", "is required");
    if (!proto.has_right()) return Invalid(field + ".right", "is required");
    if (proto.rotation_size() != 9) {
        return Invalid(field + ".rotation",
                       absl::StrCat("needs 9 values (row-major 3x3), got ", proto.rotation_size()));
    }
    if (proto.translation_m_size() != 3) {
        return Invalid(field + ".translation_m",
                       absl::StrCat("needs 3 values, got ", proto.translation_m_size()));
    }
    StereoParameters parameters;
    parameters.image_width = proto.image_width();
    parameters.image_height = proto.image_height();
    parameters.left = ToIntrinsics(proto.left());
    parameters.right = ToIntrinsics(proto.right());
    for (int i = 0; i < 9; ++i) parameters.R_right_left(i / 3, i % 3) = proto.rotation(i);
    for (int i = 0; i < 3; ++i) parameters.t_right_left_m(i) = proto.translation_m(i);
    return parameters;
}

absl::StatusOr<stereo::ChessboardSpec> ToChessboardSpec(const v1::ChessboardCalibration& proto) {
    if (!proto.has_inner_corners()) {
        return Invalid("chessboard.inner_corners", "is required ({cols, rows} of inner corners)");
    }
    if (proto.pairs_size() == 0) return Invalid("chessboard.pairs", "is empty");
    stereo::ChessboardSpec spec;
    spec.cols = proto.inner_corners().cols();
    spec.rows = proto.inner_corners().rows();
    spec.square_size_m = proto.square_size_m();
    if (spec.cols < 2 || spec.rows < 2 || spec.cols > 100 || spec.rows > 100) {
        return Invalid(
            "chessboard.inner_corners",
            absl::StrCat("cols and rows must be in [2, 100], got ", spec.cols, " x ", spec.rows));
    }
    if (!std::isfinite(spec.square_size_m) || spec.square_size_m <= 0.0 ||
        spec.square_size_m > 10.0) {
        return Invalid("chessboard.square_size_m", "must be in (0, 10] metres");
    }
    return spec;
}

absl::StatusOr<pipeline::OpeningMarks> ToOpeningMarks(const v1::Opening& proto, bool stereo_scan) {
    const int corners = proto.corners_size();
    const int pixels = proto.pixel_corners_size();
    if ((corners == 0) == (pixels == 0)) {
        return Invalid("opening", "give either corners (3D) or pixel_corners, exactly one of them");
    }
    if (pixels > 0) {
        if (!stereo_scan) {
            return Invalid("opening.pixel_corners", "need a stereo scan; give corners for a cloud");
        }
        if (pixels != 4) {
            return Invalid("opening.pixel_corners", absl::StrCat("needs 4 corners, got ", pixels));
        }
        stereo::PixelCorners marks;
        for (int i = 0; i < 4; ++i) {
            marks[i] = {proto.pixel_corners(i).u(), proto.pixel_corners(i).v()};
            if (!marks[i].allFinite()) {
                return Invalid(absl::StrCat("opening.pixel_corners[", i, "]"), "is not finite");
            }
        }
        return marks;
    }
    if (corners != 4)
        return Invalid("opening.corners", absl::StrCat("needs 4 corners, got ", corners));
    Corners marks;
    for (int i = 0; i < 4; ++i) {
        marks[i] = {proto.corners(i).x(), proto.corners(i).y(), proto.corners(i).z()};
        if (!marks[i].allFinite()) {
            return Invalid(absl::StrCat("opening.corners[", i, "]"), "is not finite");
        }
    }
    return marks;
}

void ToProto(const StereoParameters& parameters, v1::StereoParameters* proto) {
    proto->set_image_width(parameters.image_width);
    proto->set_image_height(parameters.image_height);
    ToProto(parameters.left, proto->mutable_left());
    ToProto(parameters.right, proto->mutable_right());
    proto->clear_rotation();
    proto->clear_translation_m();
    for (int i = 0; i < 9; ++i) proto->add_rotation(parameters.R_right_left(i / 3, i % 3));
    for (int i = 0; i < 3; ++i) proto->add_translation_m(parameters.t_right_left_m(i));
}

absl::StatusOr<stereo::StereoCalibration> ToStereoCalibration(const v1::Calibration& proto) {
    absl::StatusOr<StereoParameters> parameters =
        ToStereoParameters(proto.parameters(), "parameters");
    if (!parameters.ok()) return parameters.status();
    absl::StatusOr<stereo::StereoCalibration> calibration =
        stereo::CalibrationFromParameters(*parameters);
    if (!calibration.ok()) {  // the core names its field within the parameters
        return absl::Status(calibration.status().code(),
                            absl::StrCat("parameters.", calibration.status().message()));
    }
    calibration->source =
        proto.source() == v1::CALIBRATION_SOURCE_CHESSBOARD ? "chessboard" : "parameters";
    calibration->rms_reprojection_px = proto.rms_reprojection_error_px();
    calibration->mean_epipolar_px = proto.mean_epipolar_error_px();
    for (const v1::SkippedPair& skipped : proto.skipped_pairs()) {
        calibration->skipped.push_back({skipped.index(), skipped.reason()});
    }
    return calibration;
}

void ToProto(const stereo::StereoCalibration& calibration, v1::Calibration* proto) {
    proto->set_source(calibration.source == "chessboard" ? v1::CALIBRATION_SOURCE_CHESSBOARD
                                                         : v1::CALIBRATION_SOURCE_PARAMETERS);
    proto->set_image_width(calibration.parameters.image_width);
    proto->set_image_height(calibration.parameters.image_height);
    proto->set_baseline_m(calibration.baseline_m);
    proto->set_focal_length_px(calibration.focal_px);
    proto->set_rms_reprojection_error_px(calibration.rms_reprojection_px);
    proto->set_mean_epipolar_error_px(calibration.mean_epipolar_px);
    proto->set_pairs_used(static_cast<int>(calibration.pairs.size()));
    proto->clear_skipped_pairs();
    for (const stereo::SkippedPair& skipped : calibration.skipped) {
        v1::SkippedPair* out = proto->add_skipped_pairs();
        out->set_index(skipped.index);
        out->set_reason(skipped.reason);
    }
    ToProto(calibration.parameters, proto->mutable_parameters());
}

void ToProto(const model::ContainerModel& model, v1::Container* proto) {
    proto->set_struck_capacity_m3(model.struck_capacity_m3);
    proto->set_heaped_capacity_m3(model.heaped_capacity_sae_m3);
    proto->set_heaped_capacity_iso_m3(model.heaped_capacity_iso_m3);
    proto->set_opening_area_m2(model.opening.area_m2);
    proto->set_depth_m(model.depth_m);
    proto->set_noise_sigma_m(model.noise_sigma_m);
    proto->clear_opening_corners();
    for (const Eigen::Vector2d& corner : model.opening.polygon.Vertices()) {
        AddPoint(model.opening.T_scan_container * Eigen::Vector3d(corner.x(), corner.y(), 0.0),
                 proto->mutable_opening_corners());
    }
    proto->set_scan_points(static_cast<int32_t>(model.scan_points));
    proto->set_alignment_points(static_cast<int32_t>(model.alignment_points.size()));
    proto->set_observed_share(model.observed_share);
    proto->set_empty_scans(static_cast<int32_t>(model.cavity.size()));
    ToProto(model.opening.T_scan_container, proto->mutable_container_pose());
    proto->set_struck_capacity_uncertainty_m3(model.struck_capacity_sigma_m3);
    proto->clear_unseen_sides();
    for (const model::UnseenSide& side : model.unseen) {
        v1::UnseenSide* out = proto->add_unseen_sides();
        out->set_from_corner(side.from_corner);
        out->set_to_corner(side.to_corner);
        out->set_area_m2(side.area_m2);
        out->set_uncertainty_m3(side.sigma_m3);
    }
    proto->set_has_mesh(!model.mesh.triangles.empty());
}

absl::StatusOr<Pose> ToPose(const v1::Pose& proto, const std::string& field) {
    const v1::Point3& p = proto.position_m();
    const v1::Quaternion& q = proto.orientation();
    for (const double value : {p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z()}) {
        if (!std::isfinite(value)) {
            return absl::InvalidArgumentError(absl::StrCat(field, ": values must be finite"));
        }
    }
    if (std::abs(p.x()) > kMaxCoordinateM || std::abs(p.y()) > kMaxCoordinateM ||
        std::abs(p.z()) > kMaxCoordinateM) {
        return absl::InvalidArgumentError(absl::StrCat(field, ".position_m: farther than ",
                                                       kMaxCoordinateM, " m from the sensor"));
    }
    Eigen::Quaterniond rotation(q.w(), q.x(), q.y(), q.z());
    const double norm = rotation.norm();
    if (norm == 0.0) {
        rotation = Eigen::Quaterniond::Identity();
    } else if (std::abs(norm - 1.0) > 1e-3) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".orientation: is not a unit quaternion (norm ", norm, ")"));
    }
    Pose pose = Pose::Identity();
    pose.linear() = rotation.normalized().toRotationMatrix();
    pose.translation() = Eigen::Vector3d(p.x(), p.y(), p.z());
    return pose;
}

void ToProto(const volume::VolumeResult& volume, v1::Heightmap* proto) {
    proto->set_heights_f32le(volume::PackedHeights(volume));
    proto->set_cols(volume.grid.cols);
    proto->set_rows(volume.grid.rows);
    proto->set_cell_m(volume.grid.cell_m);
    proto->set_origin_x_m(volume.grid.origin.x());
    proto->set_origin_y_m(volume.grid.origin.y());
}

void ToProto(const Pose& pose, v1::Pose* proto) {
    v1::Point3* position = proto->mutable_position_m();
    position->set_x(pose.translation().x());
    position->set_y(pose.translation().y());
    position->set_z(pose.translation().z());
    Eigen::Quaterniond q(pose.linear());
    q.normalize();
    if (q.w() < 0.0) q.coeffs() *= -1.0;  // one of the two equal quaternions: w >= 0
    v1::Quaternion* orientation = proto->mutable_orientation();
    orientation->set_w(q.w());
    orientation->set_x(q.x());
    orientation->set_y(q.y());
    orientation->set_z(q.z());
}

void ToProto(const pipeline::VolumeEstimate& estimate, v1::EstimateVolumeResponse* proto) {
    proto->set_volume_m3(estimate.volume_m3);
    proto->set_fill_ratio(estimate.fill_ratio_struck);
    proto->set_fill_ratio_heaped(estimate.fill_ratio_heaped);
    proto->set_uncertainty_m3(estimate.uncertainty_m3);
    v1::Alignment* alignment = proto->mutable_alignment();
    alignment->set_fitness(estimate.alignment.fitness);
    alignment->set_rmse_m(estimate.alignment.rmse_m);
    alignment->set_converged(estimate.alignment.converged);
    alignment->set_iterations(estimate.alignment.iterations);
    alignment->set_correspondences(static_cast<int32_t>(estimate.alignment.correspondences));
    v1::CellCounts* cells = proto->mutable_cells();
    cells->set_cell_m(estimate.volume.grid.cell_m);
    cells->set_total(estimate.volume.cells.total);
    cells->set_measured(estimate.volume.cells.measured);
    cells->set_interpolated(estimate.volume.cells.interpolated);
    cells->set_with_soil(estimate.volume.cells.with_soil);
    v1::Timings* timings = proto->mutable_timings();
    timings->set_preprocess_ms(estimate.timings.range_ms + estimate.timings.outliers_ms);
    timings->set_align_ms(estimate.timings.align_ms);
    timings->set_volume_ms(estimate.timings.volume_ms);
    proto->set_scan_points(static_cast<int32_t>(estimate.input_points));
    proto->set_used_points(static_cast<int32_t>(estimate.preprocessed_points));
    v1::Coverage* coverage = proto->mutable_coverage();
    coverage->set_model_observed_share(estimate.volume.empty_observed_share);
    coverage->set_scan_observed_share(estimate.volume.scan_observed_share);
    coverage->set_unobserved_uncertainty_m3(estimate.volume.unobserved_uncertainty_m3);
    ToProto(estimate.alignment.T_scan_container, proto->mutable_container_pose());
    const volume::LoadDistribution load = volume::DistributionOf(estimate.volume);
    v1::LoadDistribution* distribution = proto->mutable_distribution();
    distribution->set_centre_x_m(load.centre_m.x());
    distribution->set_centre_y_m(load.centre_m.y());
    distribution->set_positive_x_share(load.positive_x_share);
    distribution->set_positive_y_share(load.positive_y_share);
    distribution->set_asymmetry(load.asymmetry);
    if (estimate.from_kinematic) {
        v1::PoseDifference* difference = proto->mutable_pose_difference();
        const Eigen::Vector3d& t = estimate.from_kinematic->translation_m;
        difference->mutable_translation_m()->set_x(t.x());
        difference->mutable_translation_m()->set_y(t.y());
        difference->mutable_translation_m()->set_z(t.z());
        difference->set_distance_m(estimate.from_kinematic->distance_m);
        difference->set_rotation_deg(estimate.from_kinematic->rotation_deg);
    }
}

}  // namespace soilvol::server

namespace soilvol::server {

google::protobuf::Timestamp NowTimestamp() {
    const auto micros = std::chrono::duration_cast<std::chrono::microseconds>(
                            std::chrono::system_clock::now().time_since_epoch())
                            .count();
    return google::protobuf::util::TimeUtil::MicrosecondsToTimestamp(micros);
}

std::int64_t NowMicros() {
    return google::protobuf::util::TimeUtil::TimestampToMicroseconds(NowTimestamp());
}

absl::StatusOr<std::string> HeightmapPng(const v1::EstimateVolumeResponse& estimate, int cell_px) {
    const v1::Heightmap& map = estimate.heightmap();
    if (map.cols() == 0 || map.rows() == 0) {
        return absl::FailedPreconditionError("the estimate was recorded without a heightmap");
    }
    absl::StatusOr<std::vector<float>> heights =
        volume::UnpackHeights(map.heights_f32le(), map.cols(), map.rows());
    if (!heights.ok()) return absl::DataLossError(heights.status().message());
    std::optional<std::pair<double, double>> centre;
    if (estimate.has_distribution() && map.cell_m() > 0.0) {
        centre = std::make_pair(
            (estimate.distribution().centre_x_m() - map.origin_x_m()) / map.cell_m(),
            (estimate.distribution().centre_y_m() - map.origin_y_m()) / map.cell_m());
    }
    return stereo::EncodePng(
        volume::RenderHeightmap(*heights, map.cols(), map.rows(), cell_px, centre));
}

absl::StatusOr<LoadRules> ToLoadRules(const v1::Material& material,
                                      const v1::LoadTargets& targets) {
    LoadRules out;
    out.material.name = material.name();
    out.material.density_kg_m3 = material.density_kg_m3();
    if (material.bulking_factor() != 0.0) out.material.bulking_factor = material.bulking_factor();
    volume::LoadTargets& t = out.targets;
    switch (targets.target_case()) {
        case v1::LoadTargets::kVolumeM3:
            t.quantity = volume::LoadTargets::Quantity::kVolume;
            t.target = targets.volume_m3();
            break;
        case v1::LoadTargets::kPayloadKg:
            t.quantity = volume::LoadTargets::Quantity::kPayload;
            t.target = targets.payload_kg();
            break;
        case v1::LoadTargets::TARGET_NOT_SET:
            break;
    }
    if (targets.has_under_tolerance()) t.under_tolerance = targets.under_tolerance();
    if (targets.has_over_tolerance()) t.over_tolerance = targets.over_tolerance();
    t.carryback_m3 = targets.carryback_m3();
    t.empty_m3 = targets.empty_m3();
    SOILVOL_RETURN_IF_ERROR(volume::CheckLoadRules(out.material, out.targets));
    return out;
}

void ToProto(const volume::LoadAssessment& load, v1::LoadAssessment* out) {
    switch (load.status) {
        case volume::LoadStatus::kEmpty:
            out->set_status(v1::LOAD_STATUS_EMPTY);
            break;
        case volume::LoadStatus::kCarryback:
            out->set_status(v1::LOAD_STATUS_CARRYBACK);
            break;
        case volume::LoadStatus::kUnderloaded:
            out->set_status(v1::LOAD_STATUS_UNDERLOADED);
            break;
        case volume::LoadStatus::kLoadedOk:
            out->set_status(v1::LOAD_STATUS_LOADED_OK);
            break;
        case volume::LoadStatus::kOverloaded:
            out->set_status(v1::LOAD_STATUS_OVERLOADED);
            break;
        case volume::LoadStatus::kLoaded:
            out->set_status(v1::LOAD_STATUS_LOADED);
            break;
    }
    out->set_status_probability(load.status_probability);
    if (load.target_ratio) out->set_target_ratio(*load.target_ratio);
    if (load.bank_volume_m3) out->set_bank_volume_m3(*load.bank_volume_m3);
    if (load.mass_sigma_kg) out->set_mass_uncertainty_kg(*load.mass_sigma_kg);
    out->set_empty_threshold_m3(load.empty_threshold_m3);
}

absl::StatusOr<std::int64_t> TimestampMicros(const google::protobuf::Timestamp& time,
                                             const char* field) {
    // The range of RFC 3339 (years 1..9999), as google.protobuf.Timestamp defines it.
    constexpr std::int64_t kMinSeconds = -62135596800, kMaxSeconds = 253402300799;
    if (time.seconds() < kMinSeconds || time.seconds() > kMaxSeconds || time.nanos() < 0 ||
        time.nanos() > 999999999) {
        return absl::InvalidArgumentError(absl::StrCat(field, ": not a valid timestamp"));
    }
    return google::protobuf::util::TimeUtil::TimestampToMicroseconds(time);
}

absl::Status TimeRangeMicros(const google::protobuf::Timestamp* start,
                             const google::protobuf::Timestamp* end, std::int64_t* start_us,
                             std::int64_t* end_us) {
    if (start != nullptr) {
        const absl::StatusOr<std::int64_t> micros = TimestampMicros(*start, "start_time");
        if (!micros.ok()) return micros.status();
        *start_us = *micros;
    }
    if (end != nullptr) {
        const absl::StatusOr<std::int64_t> micros = TimestampMicros(*end, "end_time");
        if (!micros.ok()) return micros.status();
        *end_us = *micros;
    }
    if (*end_us <= *start_us) {
        return absl::InvalidArgumentError("end_time: must be after start_time");
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
