#include "core/pipeline/estimator.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "core/cloud/ray_weights.hpp"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/model/model_cache.hpp"

namespace soilvol::pipeline {
namespace {

// The pose is wrong when the scan lies below the empty container over much of the opening.
absl::Status CheckContents(const volume::VolumeResult& volume, const EstimateConfig& config) {
    const int both = volume.cells.both_measured;
    if (both == 0 || config.method == volume::Method::kPaper) return absl::OkStatus();
    const double share = static_cast<double>(volume.cells.below_empty) / both;
    if (share <= config.max_below_empty_share) return absl::OkStatus();
    return absl::FailedPreconditionError(absl::StrFormat(
        "alignment rejected: the scan lies below the empty container in %.0f%% of the cells "
        "(%d of %d; at most %.0f%%): the container is not where the alignment put it",
        100.0 * share, volume.cells.below_empty, both, 100.0 * config.max_below_empty_share));
}

constexpr double kPi = 3.14159265358979323846;
constexpr double kMaxKinematicSigmaM = 1.0;
constexpr double kMaxKinematicSigmaDeg = 30.0;
/// Correspondences farther apart than this match the wrong surfaces whatever the pose's error.
constexpr double kMaxKinematicReachM = 1.0;

double TurnDeg(const Pose& a, const Pose& b) {
    return Eigen::AngleAxisd((a.inverse() * b).linear()).angle() * 180.0 / kPi;
}

// A local alignment that explains little of the model is checked against a global search on
// the container's outside: the better explanation wins, and two poses that explain the scan
// alike, apart, are no answer.
absl::StatusOr<align::AlignResult> SearchWider(const model::ContainerModel& model,
                                               const Cloud& scan, const Pose& initial,
                                               align::AlignResult local,
                                               const EstimateConfig& config,
                                               const StopToken& stop) {
    const Eigen::Vector3d sensor =
        model::SensorInContainer(model.opening.T_scan_container, model.opening.polygon);
    const std::optional<Pose> coarse =
        align::GlobalAlign(model.alignment_points, sensor, scan, config.global, initial, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("global alignment"));
    if (!coarse) return local;
    align::AlignResult global = model::AlignModel(model, scan, *coarse, config.align, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("alignment from the global pose"));
    if (!align::CheckAlignment(global, config.gate).ok()) return local;
    const bool local_ok = align::CheckAlignment(local, config.gate).ok();
    if (!local_ok || global.fitness > local.fitness + config.global_fitness_margin) return global;
    const double apart_m =
        (local.T_scan_container.translation() - global.T_scan_container.translation()).norm();
    const double apart_deg = TurnDeg(local.T_scan_container, global.T_scan_container);
    if (global.fitness + config.global_fitness_margin >= local.fitness &&
        (apart_m > config.distinct_pose_m || apart_deg > config.distinct_pose_deg)) {
        return absl::FailedPreconditionError(absl::StrFormat(
            "alignment ambiguous: two poses %.2f m / %.1f deg apart explain the scan alike "
            "(fitness %.3f and %.3f); give the container's pose (initial pose) or scan it with "
            "more of its outside in view",
            apart_m, apart_deg, local.fitness, global.fitness));
    }
    return local;
}

// The model's outside must not float in space the scan's rays crossed: each sensor's rays are
// tested from where that sensor stood.
absl::StatusOr<align::SeenThrough> CheckFreeSpace(const model::ContainerModel& model,
                                                  const std::vector<SensorCloud>& sensors,
                                                  const align::AlignResult& alignment,
                                                  const EstimateConfig& config) {
    align::SeenThrough seen;
    for (const SensorCloud& sensor : sensors) {
        const Pose T_sensor_container = sensor.T_scan_sensor.inverse() * alignment.T_scan_container;
        const align::SeenThrough own =
            align::SeenThroughShare(model::ToScanFrame(model.alignment_points, T_sensor_container),
                                    sensor.points, model.noise_sigma_m, config.seen_through);
        seen.tested += own.tested;
        seen.through += own.through;
    }
    if (seen.Share() <= config.max_seen_through_share) return seen;
    return absl::FailedPreconditionError(absl::StrFormat(
        "alignment rejected: the scan sees through %.0f%% of the container's outside at the "
        "found pose (%zu of %zu points with returns in their direction; at most %.0f%%): the "
        "container is not where the alignment put it; give its pose (initial pose)",
        100.0 * seen.Share(), seen.through, seen.tested, 100.0 * config.max_seen_through_share));
}

// The returns of one sensor (container frame) that can be contents, weighted along their rays
// from `sensor` (container frame): the container's own rim and outside are not contents (a
// return under the opening whose ray came through a wall is the wall's outside).
absl::StatusOr<WeightedCloud> ContentsSeenFrom(const model::ContainerModel& model,
                                               const Cloud& aligned, const Eigen::Vector3d& sensor,
                                               const EstimateConfig& config,
                                               const StopToken& stop) {
    const Polygon2d& opening = model.opening.polygon;
    WeightedCloud selected =
        volume::SelectColumn(aligned, {}, sensor, opening, -model.depth_m, config.heightmap);
    selected.points = model::ThroughOpening(std::move(selected.points), sensor, opening);
    SOILVOL_RETURN_IF_ERROR(stop.Check("structure removal"));
    WeightedCloud column = model::RemoveStructure(model, selected);
    SOILVOL_RETURN_IF_ERROR(stop.Check("ray weights"));
    column.weights = cloud::RayWeights(column.points, sensor, model.noise_sigma_m,
                                       config.heightmap.ray_weights, stop);
    column.sensor = sensor;
    SOILVOL_RETURN_IF_ERROR(stop.Check("ray weights"));
    return column;
}

// Sec. 3.1 for one sensor's cloud, from where that sensor stood.
void PreprocessInto(const Cloud& points, const Pose& T_scan_sensor, const EstimateConfig& config,
                    const StopToken& stop, VolumeEstimate& estimate,
                    std::vector<SensorCloud>& sensors) {
    cloud::PreprocessResult pre = cloud::Preprocess(points, config.preprocess, stop);
    estimate.input_points += points.size();
    estimate.preprocessed_points += pre.points.size();
    estimate.timings.range_ms += pre.range_ms;
    estimate.timings.outliers_ms += pre.outliers_ms + pre.voxel_ms;
    sensors.push_back({std::move(pre.points), T_scan_sensor});
}

// Every sensor's returns in the scan frame.
Cloud InScanFrame(const std::vector<SensorCloud>& sensors) {
    Cloud all;
    for (const SensorCloud& sensor : sensors) {
        const Cloud placed = model::ToScanFrame(sensor.points, sensor.T_scan_sensor);
        all.insert(all.end(), placed.begin(), placed.end());
    }
    return all;
}

// 1-sigma of the volume from the alignment's full pose covariance: the covariance, over a left
// perturbation in the scan frame, carried into the container frame (adjoint of the inverse
// pose) and projected on the volume's pose gradient.
double AlignmentSigma(const volume::VolumeResult& volume, const align::AlignResult& alignment) {
    const Eigen::Matrix3d R = alignment.T_scan_container.linear();
    const Eigen::Vector3d p = alignment.T_scan_container.translation();
    const Eigen::Vector3d q = -R.transpose() * p;
    Eigen::Matrix3d q_hat;
    q_hat << 0.0, -q.z(), q.y(), q.z(), 0.0, -q.x(), -q.y(), q.x(), 0.0;
    Eigen::Matrix<double, 6, 6> adjoint = Eigen::Matrix<double, 6, 6>::Zero();
    adjoint.topLeftCorner<3, 3>() = R.transpose();
    adjoint.bottomLeftCorner<3, 3>() = q_hat * R.transpose();
    adjoint.bottomRightCorner<3, 3>() = R.transpose();
    const Eigen::Matrix<double, 6, 6> covariance =
        adjoint * alignment.covariance * adjoint.transpose();
    const Eigen::Matrix<double, 6, 1> g = volume::VolumePoseGradient(volume);
    return std::sqrt(std::max(0.0, g.dot(covariance * g)));
}

// An answer whose 1-sigma exceeds the budget is not an answer: the caller gets the figures and
// what would help instead of a number that may be off by more than twice the budget.
absl::Status CheckUncertainty(const VolumeEstimate& estimate, const model::ContainerModel& model,
                              const EstimateConfig& config) {
    if (config.method == volume::Method::kPaper || config.max_uncertainty_share <= 0.0 ||
        model.struck_capacity_m3 <= 0.0) {
        return absl::OkStatus();
    }
    const double share = estimate.uncertainty_m3 / model.struck_capacity_m3;
    if (share <= config.max_uncertainty_share) return absl::OkStatus();
    const volume::VolumeResult& v = estimate.volume;
    return absl::FailedPreconditionError(absl::StrFormat(
        "uncertain estimate refused: 1-sigma %.1f L is %.1f%% of the struck capacity (at most "
        "%.1f%%); the scan saw %.0f%% of the opening, the empty scans %.0f%% (unseen parts: "
        "%.1f L); scan the contents from where more of the opening is visible, or register "
        "more empty scans",
        1000.0 * estimate.uncertainty_m3, 100.0 * share, 100.0 * config.max_uncertainty_share,
        100.0 * v.scan_observed_share, 100.0 * v.empty_observed_share,
        1000.0 * v.unobserved_uncertainty_m3));
}

/// The coarse alignment searches as far as the kinematic pose may be off (3 sigmas of position
/// plus what 3 sigmas of rotation move the container's farthest corner), at least as far as
/// it does from the registered pose.
align::AlignConfig KinematicSearch(const model::ContainerModel& model,
                                   const EstimateConfig& config) {
    align::AlignConfig align = config.align;
    double radius = 0.0;
    for (const Eigen::Vector2d& corner : model.opening.polygon.Vertices()) {
        radius = std::max(radius, corner.norm());
    }
    const double reach =
        config.kinematic_sigmas * (config.kinematic_position_sigma_m +
                                   radius * config.kinematic_orientation_sigma_deg * kPi / 180.0);
    // Never narrower than without kinematics: a narrow search stops short of the true pose.
    align.coarse_max_correspondence_m =
        std::clamp(reach, align.coarse_max_correspondence_m, kMaxKinematicReachM);
    align.coarse_column_margin_m =
        std::max(align.coarse_column_margin_m, align.coarse_max_correspondence_m);
    return align;
}

absl::Status CheckKinematic(const PoseDifference& difference, const EstimateConfig& config) {
    const double max_m =
        config.kinematic_sigmas * config.kinematic_position_sigma_m + config.kinematic_floor_m;
    const double max_deg = config.kinematic_sigmas * config.kinematic_orientation_sigma_deg +
                           config.kinematic_floor_deg;
    if (difference.distance_m <= max_m && difference.rotation_deg <= max_deg) {
        return absl::OkStatus();
    }
    return absl::FailedPreconditionError(absl::StrFormat(
        "container_pose: the scan puts the container %.3f m and %.2f deg from the given pose, "
        "more than the stated accuracy allows (%.3f m, %.2f deg at %.0f sigmas); check the "
        "kinematics and the sensor mount, or state a larger accuracy",
        difference.distance_m, difference.rotation_deg, max_m, max_deg, config.kinematic_sigmas));
}

}  // namespace

PoseDifference DifferenceOf(const Pose& given, const Pose& found) {
    PoseDifference out;
    out.translation_m = found.translation() - given.translation();
    out.distance_m = out.translation_m.norm();
    out.rotation_deg = TurnDeg(given, found);
    return out;
}

absl::Status SetKinematicAccuracy(double position_sigma_m, double orientation_sigma_deg,
                                  EstimateConfig& config) {
    if (!std::isfinite(position_sigma_m) || position_sigma_m < 0.0 ||
        position_sigma_m > kMaxKinematicSigmaM) {
        return absl::InvalidArgumentError(
            absl::StrFormat("container_pose.position_sigma_m: must be in [0, %g] metres (0: %g)",
                            kMaxKinematicSigmaM, config.kinematic_position_sigma_m));
    }
    if (!std::isfinite(orientation_sigma_deg) || orientation_sigma_deg < 0.0 ||
        orientation_sigma_deg > kMaxKinematicSigmaDeg) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "container_pose.orientation_sigma_deg: must be in [0, %g] degrees (0: %g)",
            kMaxKinematicSigmaDeg, config.kinematic_orientation_sigma_deg));
    }
    if (position_sigma_m > 0.0) config.kinematic_position_sigma_m = position_sigma_m;
    if (orientation_sigma_deg > 0.0) config.kinematic_orientation_sigma_deg = orientation_sigma_deg;
    return absl::OkStatus();
}

absl::StatusOr<ScanAlignment> AlignScan(const model::ContainerModel& model, const Cloud& scan,
                                        const std::vector<SensorCloud>& sensors,
                                        const EstimateConfig& config, const StopToken& stop) {
    // Sec. 3.3: align the model's outside to the scan.
    ScanAlignment out;
    const Pose initial = config.initial_T_scan_container.value_or(model.opening.T_scan_container);
    out.alignment = model::AlignModel(
        model, scan, initial,
        config.initial_T_scan_container ? KinematicSearch(model, config) : config.align, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("alignment"));
    if (!config.initial_T_scan_container && config.method == volume::Method::kHeightmap &&
        config.global_search_below_fitness >= 0.0 &&
        (out.alignment.fitness < config.global_search_below_fitness ||
         !align::CheckAlignment(out.alignment, config.gate).ok())) {
        SOILVOL_ASSIGN_OR_RETURN(
            out.alignment,
            SearchWider(model, scan, initial, std::move(out.alignment), config, stop));
    }
    SOILVOL_RETURN_IF_ERROR(align::CheckAlignment(out.alignment, config.gate));
    if (config.initial_T_scan_container) {
        out.from_kinematic = DifferenceOf(initial, out.alignment.T_scan_container);
        SOILVOL_RETURN_IF_ERROR(CheckKinematic(*out.from_kinematic, config));
    }
    SOILVOL_ASSIGN_OR_RETURN(out.seen_through,
                             CheckFreeSpace(model, sensors, out.alignment, config));
    return out;
}

volume::EmptySide EmptySideOf(const model::ContainerModel& model, const EstimateConfig& config,
                              const StopToken& stop) {
    if (!model.cache) {
        return {volume::EmptyMinZ(model.cavity),
                [&model, &config, &stop](const volume::Grid& grid)
                    -> absl::StatusOr<std::shared_ptr<const volume::EmptySurface>> {
                    SOILVOL_ASSIGN_OR_RETURN(
                        volume::EmptySurface surface,
                        model::ModelEmptySurface(model, grid, config.heightmap, stop));
                    return std::make_shared<const volume::EmptySurface>(std::move(surface));
                }};
    }
    model::ModelCache& cache = *model.cache;
    return {cache.EmptyMinZ(model), [&model, &cache, &config, &stop](const volume::Grid& grid) {
                return cache.EmptySurface(model, grid, config.heightmap, stop);
            }};
}

absl::StatusOr<volume::VolumeResult> IntegrateVolume(const model::ContainerModel& model,
                                                     const Cloud& aligned,
                                                     const Pose& T_scan_container,
                                                     const EstimateConfig& config,
                                                     const StopToken& stop) {
    if (config.method == volume::Method::kPaper) {
        const WeightedCloud column =
            volume::SelectColumn(aligned, {}, Eigen::Vector3d::Zero(), model.opening.polygon,
                                 -model.depth_m, config.heightmap);
        return volume::PaperVolume(model.inside, column.points, model.opening.polygon, config.paper,
                                   stop);
    }
    return IntegrateVolume(model, aligned, T_scan_container, config,
                           EmptySideOf(model, config, stop), stop);
}

absl::StatusOr<volume::VolumeResult> IntegrateVolume(
    const model::ContainerModel& model, const Cloud& aligned, const Pose& T_scan_container,
    const EstimateConfig& config, const volume::EmptySide& empty, const StopToken& stop) {
    const Polygon2d& opening = model.opening.polygon;
    std::vector<WeightedCloud> columns(1);
    SOILVOL_ASSIGN_OR_RETURN(
        columns[0],
        ContentsSeenFrom(model, aligned, model::SensorInContainer(T_scan_container, opening),
                         config, stop));
    return volume::HeightmapVolume(empty, columns, opening, config.heightmap, stop);
}

absl::StatusOr<volume::VolumeResult> IntegrateVolume(const model::ContainerModel& model,
                                                     const std::vector<SensorCloud>& sensors,
                                                     const Pose& T_scan_container,
                                                     const EstimateConfig& config,
                                                     const StopToken& stop) {
    const Polygon2d& opening = model.opening.polygon;
    if (config.method == volume::Method::kPaper) {
        return IntegrateVolume(model,
                               model::ToContainerFrame(InScanFrame(sensors), T_scan_container),
                               T_scan_container, config, stop);
    }
    std::vector<WeightedCloud> columns;
    for (const SensorCloud& sensor : sensors) {
        const Pose T_sensor_container = sensor.T_scan_sensor.inverse() * T_scan_container;
        SOILVOL_ASSIGN_OR_RETURN(
            WeightedCloud column,
            ContentsSeenFrom(model, model::ToContainerFrame(sensor.points, T_sensor_container),
                             model::SensorInContainer(T_sensor_container, opening), config, stop));
        columns.push_back(std::move(column));
    }
    return volume::HeightmapVolume(EmptySideOf(model, config, stop), columns, opening,
                                   config.heightmap, stop);
}

absl::StatusOr<VolumeEstimate> EstimateVolume(const model::ContainerModel& model, const Cloud& scan,
                                              const EstimateConfig& config, const StopToken& stop) {
    return EstimateVolume(model, scan, {}, config, stop);
}

absl::StatusOr<VolumeEstimate> EstimateVolume(const model::ContainerModel& model, const Cloud& scan,
                                              const std::vector<SensorCloud>& more_sensors,
                                              const EstimateConfig& config, const StopToken& stop) {
    VolumeEstimate estimate;
    Timer total;
    Timer timer;
    // Sec. 3.1: background and outlier removal, each sensor's cloud from where it stood.
    std::vector<SensorCloud> sensors;
    sensors.reserve(1 + more_sensors.size());
    PreprocessInto(scan, Pose::Identity(), config, stop, estimate, sensors);
    for (const SensorCloud& more : more_sensors) {
        PreprocessInto(more.points, more.T_scan_sensor, config, stop, estimate, sensors);
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check("preprocessing"));
    if (estimate.input_points == 0) return absl::InvalidArgumentError("scan has no points");
    if (estimate.preprocessed_points == 0) {
        return absl::InvalidArgumentError("no scan point is left after range and outlier removal");
    }
    timer.Lap();
    // Sec. 3.3: one sensor's cloud is the scan; several are placed in the first one's frame.
    const Cloud placed = sensors.size() == 1 ? Cloud{} : InScanFrame(sensors);
    const Cloud& in_scan_frame = sensors.size() == 1 ? sensors[0].points : placed;
    SOILVOL_ASSIGN_OR_RETURN(ScanAlignment aligned,
                             AlignScan(model, in_scan_frame, sensors, config, stop));
    estimate.alignment = std::move(aligned.alignment);
    estimate.seen_through = aligned.seen_through;
    estimate.from_kinematic = aligned.from_kinematic;
    estimate.timings.align_ms = timer.Lap();  // the gate belongs to the alignment
    // Sec. 3.4: grid and integrate in the container frame.
    SOILVOL_RETURN_IF_ERROR(stop.Check("volume integration"));
    SOILVOL_ASSIGN_OR_RETURN(
        estimate.volume,
        IntegrateVolume(model, sensors, estimate.alignment.T_scan_container, config, stop));
    estimate.timings.volume_ms = timer.Lap();
    SOILVOL_RETURN_IF_ERROR(CheckContents(estimate.volume, config));
    estimate.volume_m3 = estimate.volume.volume_m3;
    estimate.pose_uncertainty_m3 = AlignmentSigma(estimate.volume, estimate.alignment);
    estimate.uncertainty_m3 =
        std::hypot(estimate.volume.uncertainty_m3, estimate.pose_uncertainty_m3);
    SOILVOL_RETURN_IF_ERROR(CheckUncertainty(estimate, model, config));
    if (model.struck_capacity_m3 > 0.0) {
        estimate.fill_ratio_struck = estimate.volume_m3 / model.struck_capacity_m3;
    }
    if (model.heaped_capacity_sae_m3 > 0.0) {
        estimate.fill_ratio_heaped = estimate.volume_m3 / model.heaped_capacity_sae_m3;
    }
    estimate.timings.total_ms = total.Lap();
    return estimate;
}

}  // namespace soilvol::pipeline
