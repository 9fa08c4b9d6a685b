#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/align/global_align.hpp"
#include "core/align/icp.hpp"
#include "core/align/seen_through.hpp"
#include "core/cloud/preprocess.hpp"
#include "core/common/stop_token.hpp"
#include "core/model/container_model.hpp"
#include "core/volume/heightmap_volume.hpp"
#include "core/volume/paper_volume.hpp"
#include "core/volume/volume_result.hpp"

namespace soilvol::pipeline {

struct EstimateConfig {
    cloud::PreprocessConfig preprocess;
    align::AlignConfig align;
    align::AlignGate gate;
    volume::Method method = volume::Method::kHeightmap;
    volume::HeightmapConfig heightmap;
    volume::PaperConfig paper;
    /// Soil never lies below the container: when the scan's surface lies 3 sigmas below the
    /// empty surface over more than this share of the cells both saw, the alignment is wrong
    /// and the estimate is refused (FailedPrecondition).
    double max_below_empty_share = 0.25;
    /// Free space against the pose: when the scan's rays passed through more than this share
    /// of the model's outside (at the found pose, among the points with returns in their
    /// direction), the container is not where the alignment put it (FailedPrecondition).
    double max_seen_through_share = 0.05;
    align::SeenThroughConfig seen_through;
    /// An estimate whose 1-sigma exceeds this share of the struck capacity is refused
    /// (FailedPrecondition, with the figures): the scan or the empty scans saw too little of
    /// the opening to know. 0 = never refused for its uncertainty.
    double max_uncertainty_share = 0.15;
    /// Container pose in the scan frame from the machine's kinematics; default: the pose it had
    /// in the empty scan.
    std::optional<Pose> initial_T_scan_container;
    /// The kinematic pose's expected accuracy (1 sigma): the coarse alignment searches 3 sigmas
    /// around it, and an alignment farther than `kinematic_sigmas` sigmas plus the floors from
    /// it is refused (FailedPrecondition): the kinematics or the scan is wrong.
    double kinematic_position_sigma_m = 0.05;
    double kinematic_orientation_sigma_deg = 2.0;
    double kinematic_sigmas = 3.0;
    double kinematic_floor_m = 0.02;
    double kinematic_floor_deg = 1.0;
    /// Without a kinematic pose, an alignment that fails the gate or matches less than this
    /// share of the model's outside is checked against a global search (`global`, 100-200 ms):
    /// the better explanation of the scan wins by `global_fitness_margin`, and two different
    /// poses that explain it alike are refused (FailedPrecondition). Off (negative) by default:
    /// the gate cannot yet tell a container's outside from a plane laid over its rim, which the
    /// global search then finds (BENCHMARK.md, Large moves).
    double global_search_below_fitness = -1.0;
    double global_fitness_margin = 0.05;
    /// Poses this far apart are different answers.
    double distinct_pose_m = 0.05;
    double distinct_pose_deg = 3.0;
    align::GlobalAlignConfig global;
};

/// Wall-clock time per stage [ms].
struct StageTimings {
    double range_ms = 0.0;
    double outliers_ms = 0.0;
    double align_ms = 0.0;
    double volume_ms = 0.0;
    double total_ms = 0.0;
};

/// The pose an alignment found against the one it was given.
struct PoseDifference {
    Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();  ///< found - given, scan frame
    double distance_m = 0.0;
    double rotation_deg = 0.0;  ///< angle of the rotation between the two
};

PoseDifference DifferenceOf(const Pose& given, const Pose& found);

/// InvalidArgument naming the field when a kinematic accuracy is out of range (position
/// (0, 1] m, orientation (0, 30] degrees; 0 takes the default).
absl::Status SetKinematicAccuracy(double position_sigma_m, double orientation_sigma_deg,
                                  EstimateConfig& config);

struct VolumeEstimate {
    double volume_m3 = 0.0;
    double uncertainty_m3 = 0.0;       ///< 1-sigma: per-cell statistics and alignment
    double pose_uncertainty_m3 = 0.0;  ///< its part from the alignment's pose covariance
    double fill_ratio_struck = 0.0;    ///< volume / struck capacity
    double fill_ratio_heaped = 0.0;    ///< volume / heaped capacity (SAE J296)
    volume::VolumeResult volume;       ///< grid, per-cell heights and counts
    align::AlignResult alignment;
    align::SeenThrough seen_through;  ///< the model's outside the scan's rays passed through
    StageTimings timings;
    std::size_t input_points = 0;
    std::size_t preprocessed_points = 0;
    /// Set when the config gave a kinematic pose.
    std::optional<PoseDifference> from_kinematic;
};

/// The alignment of the model to a preprocessed scan that passed every gate.
struct ScanAlignment {
    align::AlignResult alignment;
    align::SeenThrough seen_through;
    std::optional<PoseDifference> from_kinematic;
};

/// Sec. 3.3: aligns the model's outside to the preprocessed scan (`scan`: every sensor's returns
/// in the scan frame; `sensors`: the same returns per sensor, in its own frame) from the
/// configured or the registered pose, checked against a global search when configured, and
/// refuses a bad alignment (FailedPrecondition with the figures); the free-space test follows
/// each sensor's own rays.
absl::StatusOr<ScanAlignment> AlignScan(const model::ContainerModel& model, const Cloud& scan,
                                        const std::vector<SensorCloud>& sensors,
                                        const EstimateConfig& config, const StopToken& stop = {});

/// Sec. 3.4: the contents of the preprocessed scan in the container frame (`aligned`, taken
/// there by `T_scan_container`) by the configured method.
absl::StatusOr<volume::VolumeResult> IntegrateVolume(const model::ContainerModel& model,
                                                     const Cloud& aligned,
                                                     const Pose& T_scan_container,
                                                     const EstimateConfig& config,
                                                     const StopToken& stop = {});

/// The empty container as the model gives it to HeightmapVolume: from its cache when it has one.
volume::EmptySide EmptySideOf(const model::ContainerModel& model, const EstimateConfig& config,
                              const StopToken& stop = {});

/// IntegrateVolume (HEIGHTMAP) with the empty surface taken from `empty` instead of the model's
/// own (the error budget swaps the simulator's truth in here).
absl::StatusOr<volume::VolumeResult> IntegrateVolume(
    const model::ContainerModel& model, const Cloud& aligned, const Pose& T_scan_container,
    const EstimateConfig& config, const volume::EmptySide& empty, const StopToken& stop = {});

/// IntegrateVolume over a scan of several sensors: `sensors` (preprocessed, each in its own
/// frame, placed in the scan frame), the container at `T_scan_container`. Each sensor's returns
/// keep their own rays (weights, structure, free space); the soil surface is fitted to all.
absl::StatusOr<volume::VolumeResult> IntegrateVolume(const model::ContainerModel& model,
                                                     const std::vector<SensorCloud>& sensors,
                                                     const Pose& T_scan_container,
                                                     const EstimateConfig& config,
                                                     const StopToken& stop = {});

/// Sec. 3.1-3.4 in order: preprocess the scan, align the model's outside to it, refuse a bad
/// alignment (FailedPrecondition with the figures), integrate the soil with the chosen method.
/// InvalidArgument for an empty scan; DeadlineExceeded or Cancelled, naming the stage, once
/// `stop` asks for it.
absl::StatusOr<VolumeEstimate> EstimateVolume(const model::ContainerModel& model, const Cloud& scan,
                                              const EstimateConfig& config,
                                              const StopToken& stop = {});

/// The same over a scan several sensors took together: `scan` is the first sensor's cloud (its
/// frame is the scan frame, of every pose in the config and the answer), `more_sensors` the
/// others, each in its own frame with its pose in the scan frame. Each cloud is preprocessed
/// from its own sensor; the alignment sees all of them; every ray-based step follows each
/// return's own sensor; a cell counts as seen when any sensor saw it.
absl::StatusOr<VolumeEstimate> EstimateVolume(const model::ContainerModel& model, const Cloud& scan,
                                              const std::vector<SensorCloud>& more_sensors,
                                              const EstimateConfig& config,
                                              const StopToken& stop = {});

}  // namespace soilvol::pipeline
