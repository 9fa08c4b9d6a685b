#include "core/pipeline/estimate_policy.hpp"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/volume/grid.hpp"

namespace soilvol::pipeline {

absl::StatusOr<EstimateConfig> ConfigureEstimate(const EstimateRequest& request,
                                                 const model::ContainerModel& model,
                                                 const EstimatePolicy& policy) {
    EstimateConfig config;
    config.method = request.method;
    if (request.grid_cell_m) {
        const double cell = *request.grid_cell_m;
        if (!std::isfinite(cell) || cell < policy.min_cell_m || cell > policy.max_cell_m) {
            return absl::InvalidArgumentError(absl::StrCat("grid_cell_m: must be in [",
                                                           policy.min_cell_m, ", ",
                                                           policy.max_cell_m, "] metres"));
        }
        const double cells = volume::GridCells(model.opening.polygon, cell);
        if (cells > config.heightmap.max_cells) {
            return absl::InvalidArgumentError(absl::StrCat(
                "grid_cell_m: ", cell, " m gives ", static_cast<long long>(cells),
                " cells over the opening; at most ", config.heightmap.max_cells, " are allowed"));
        }
        const double density =
            static_cast<double>(model.inside.size()) / std::max(model.opening.area_m2, 1e-9);
        const double per_cell = density * cell * cell;
        if (config.method == volume::Method::kPaper &&
            per_cell < policy.paper_min_points_per_cell) {
            return absl::FailedPreconditionError(
                absl::StrCat("grid_cell_m: ", cell, " m cells would hold about ", per_cell,
                             " points each (registration scan density); the paper method needs ",
                             policy.paper_min_points_per_cell, ": use cells of at least ",
                             std::sqrt(policy.paper_min_points_per_cell / std::max(density, 1e-9)),
                             " m or the heightmap method"));
        }
        config.heightmap.cell_m = cell;
        config.paper.cell_m = cell;
    }
    if (request.material_density_kg_m3) {
        const double density = *request.material_density_kg_m3;
        if (!std::isfinite(density) || density <= 0.0 || density > policy.max_density_kg_m3) {
            return absl::InvalidArgumentError(absl::StrCat(
                "material_density_kg_m3: must be in (0, ", policy.max_density_kg_m3, "] kg/m^3"));
        }
    }
    if (request.kinematic_pose) {
        SOILVOL_RETURN_IF_ERROR(SetKinematicAccuracy(
            request.kinematic_position_sigma_m, request.kinematic_orientation_sigma_deg, config));
        config.initial_T_scan_container = *request.kinematic_pose;
    }
    if (request.max_range_m) config.preprocess.max_range_m = *request.max_range_m;
    return config;
}

absl::Status CheckSameSensor(const std::string& container_id, ScanKind registered,
                             const std::string& registered_calibration, ScanKind scan,
                             const std::string& scan_calibration) {
    switch (scan) {
        case ScanKind::kCloud:
        case ScanKind::kDepth:
            // Clouds and depth images are both points in the sensor's frame.
            if (registered == ScanKind::kStereo) {
                return absl::FailedPreconditionError(absl::StrCat(
                    scan == ScanKind::kDepth ? "scan.depth" : "scan.cloud", ": container '",
                    container_id, "' was registered from stereo pairs (calibration '",
                    registered_calibration, "'); send a stereo scan"));
            }
            return absl::OkStatus();
        case ScanKind::kStereo:
            if (registered != ScanKind::kStereo) {
                return absl::FailedPreconditionError(absl::StrCat(
                    "scan.stereo: container '", container_id,
                    "' was registered from a point cloud or depth image; send a cloud or depth "
                    "scan"));
            }
            if (!scan_calibration.empty() && scan_calibration != registered_calibration) {
                return absl::FailedPreconditionError(absl::StrCat(
                    "scan.stereo.calibration_id: container '", container_id,
                    "' was registered with calibration '", registered_calibration, "', not '",
                    scan_calibration, "'; register it again to use another rig"));
            }
            return absl::OkStatus();
    }
    return absl::InternalError("unknown scan kind");
}

}  // namespace soilvol::pipeline
