#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/align/icp.hpp"
#include "core/common/stop_token.hpp"
#include "core/model/container_model.hpp"

namespace soilvol::pipeline {

/// One scan of the empty container (the container may have moved between scans).
struct EmptyScan {
    Cloud points;  ///< the first sensor's returns, in its frame: the scan frame
    /// The opening corners in this scan, when marked; otherwise the alignment starts from the
    /// pose the container had in the first scan.
    std::optional<Corners> corners;
    /// The other sensors that took this scan together with the first, each in its own frame
    /// with its pose in the scan frame (a loading bridge's two lidars).
    std::vector<SensorCloud> more_sensors;
};

struct RegistrationConfig {
    std::size_t max_scans = 8;  ///< more is InvalidArgument
    /// A registration whose struck capacity's 1-sigma exceeds this share of it warns, naming
    /// the side it did not see and where to scan from.
    double max_capacity_sigma_share = 0.01;
    model::ModelConfig model;
    align::AlignConfig align;
    align::AlignGate gate;
};

struct Registration {
    model::ContainerModel model;
    /// Alignment of the model to each scan after the first (the first defines the frame).
    std::vector<align::AlignResult> alignments;
    /// What the registration could not know, for people: the capacity's 1-sigma against the
    /// configured share, with the sides to scan.
    std::vector<std::string> warnings;
};

/// The container's CAD surface: a mesh (its own frame) with its opening corners in that frame.
struct MeshInput {
    TriangleMesh mesh;
    Corners corners;
};

/// Sec. 3.2 over several empty scans: the model from the first scan and `corners` (its opening
/// corners), then each further scan aligned to the model and fused, so that what one view hid
/// another fills (ContainerModel::observed_share says how much of the opening they saw).
/// Errors of BuildContainerModel; FailedPrecondition naming the scan whose alignment fails the
/// gate; InvalidArgument for no scan, more than max_scans, or bad corners of a later scan;
/// DeadlineExceeded or Cancelled, naming the stage and scan, once `stop` asks for it.
absl::StatusOr<Registration> RegisterContainer(const Corners& corners,
                                               const std::vector<EmptyScan>& scans,
                                               const RegistrationConfig& config,
                                               const StopToken& stop = {});

/// Registration with the container's mesh: with empty scans (`corners` their first scan's), the
/// model is theirs and the mesh gives the exact inside (model::AttachMesh); without, the mesh is
/// the whole model, placed at `T_scan_mesh` before the sensor with range noise `range_noise_m`
/// (model::BuildMeshModel). Errors of those and of RegisterContainer; InvalidArgument naming
/// the field when neither scans nor a pose are given.
absl::StatusOr<Registration> RegisterWithMesh(const MeshInput& mesh, const Corners& corners,
                                              const std::vector<EmptyScan>& scans,
                                              const std::optional<Pose>& T_scan_mesh,
                                              double range_noise_m,
                                              const RegistrationConfig& config,
                                              const StopToken& stop = {});

/// The warnings of a registration of `model` (RegistrationConfig::max_capacity_sigma_share).
std::vector<std::string> CapacityWarnings(const model::ContainerModel& model,
                                          double max_capacity_sigma_share);

}  // namespace soilvol::pipeline
