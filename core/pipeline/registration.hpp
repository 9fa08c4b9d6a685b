#pragma once

#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/align/icp.hpp"
#include "core/common/stop_token.hpp"
#include "core/model/container_model.hpp"

namespace soilvol::pipeline {

/// One scan of the empty container (scan frame; one sensor, the container may have moved).
struct EmptyScan {
    Cloud points;
    /// The opening corners in this scan, when marked; otherwise the alignment starts from the
    /// pose the container had in the first scan.
    std::optional<Corners> corners;
};

struct RegistrationConfig {
    std::size_t max_scans = 8;  ///< more is InvalidArgument
    model::ModelConfig model;
    align::AlignConfig align;
    align::AlignGate gate;
};

struct Registration {
    model::ContainerModel model;
    /// Alignment of the model to each scan after the first (the first defines the frame).
    std::vector<align::AlignResult> alignments;
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

}  // namespace soilvol::pipeline
