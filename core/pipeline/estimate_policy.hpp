#pragma once

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/model/container_model.hpp"
#include "core/pipeline/estimator.hpp"

namespace soilvol::pipeline {

/// What a caller asks of one estimate, before it is checked against the container: the rules
/// every caller (server, bench, CLI) gets from ConfigureEstimate.
struct EstimateRequest {
    volume::Method method = volume::Method::kHeightmap;
    std::optional<double> grid_cell_m;  ///< unset: automatic (heightmap) or 0.10 m (paper)
    std::optional<double> material_density_kg_m3;
    std::optional<Pose> kinematic_pose;       ///< container in the scan frame, from the machine
    double kinematic_position_sigma_m = 0.0;  ///< 0: EstimateConfig's default
    double kinematic_orientation_sigma_deg = 0.0;
    std::optional<double> max_range_m;  ///< the container's registered range cut
};

/// Limits of an estimate request.
struct EstimatePolicy {
    double min_cell_m = 0.005;
    double max_cell_m = 2.0;
    double max_density_kg_m3 = 30000.0;
    /// The paper's per-cell planes need points in (nearly) every cell; below this many per cell
    /// (at the registration scan's density) its hole filling extrapolates far planes.
    double paper_min_points_per_cell = 4.0;
};

/// The engine configuration for `request` on `model`. InvalidArgument naming the field for a
/// cell size out of range or giving more than HeightmapConfig::max_cells cells, a density out
/// of range, a bad kinematic accuracy; FailedPrecondition for paper cells too small for the
/// registration's point density.
absl::StatusOr<EstimateConfig> ConfigureEstimate(const EstimateRequest& request,
                                                 const model::ContainerModel& model,
                                                 const EstimatePolicy& policy = {});

/// How a scan or a registration was taken: the model lives in that sensor's frame.
enum class ScanKind { kCloud, kStereo, kDepth };

/// A scan must come from the kind of sensor the container was registered from and, for stereo,
/// through the same calibration (`scan_calibration` empty: the container's own).
/// FailedPrecondition naming the scan field otherwise.
absl::Status CheckSameSensor(const std::string& container_id, ScanKind registered,
                             const std::string& registered_calibration, ScanKind scan,
                             const std::string& scan_calibration);

}  // namespace soilvol::pipeline
