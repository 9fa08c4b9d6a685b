#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/model/container_model.hpp"

namespace soilvol::model {

/// The model of a container from its CAD surface (a triangle mesh, e.g. io::DecodeMesh's):
/// paper Sec. 3.2 without an empty scan. Where the sensor sees the container from, the mesh
/// is ray-cast into an empty scan with the sensor's range noise (given), which gives the
/// alignment set and the structure as a real empty scan would; the mesh itself gives the exact
/// empty surface and capacities (ModelEmptySurface), every cell observed.
struct MeshModelConfig {
    ModelConfig model;
    double angular_step_deg = 0.2;           ///< the virtual scan's ray spacing, at most
    std::size_t max_virtual_rays = 1000000;  ///< a coarser spacing keeps the rays below this
    double min_noise_m = 0.001, max_noise_m = 0.5;
    uint64_t noise_seed = 1;  ///< the virtual scan's range noise
};

/// `mesh` (mesh frame) with its opening `corners_mesh` (mesh frame, ordered around the
/// opening) placed at `T_scan_mesh` before a sensor at the scan frame's origin whose range noise
/// is `range_noise_m`. InvalidArgument for bad corners, a noise outside the config's range, or a
/// mesh the sensor does not see; errors of BuildContainerModel otherwise.
absl::StatusOr<ContainerModel> BuildMeshModel(const TriangleMesh& mesh, const Corners& corners_mesh,
                                              const Pose& T_scan_mesh, double range_noise_m,
                                              const MeshModelConfig& config,
                                              const StopToken& stop = {});

/// The exact inside for a model built from empty scans: `mesh` placed by its own opening
/// corners `corners_mesh` (mesh frame, marked in the same order as the scan's) onto the model's
/// opening; the model keeps its alignment set and structure from the scans and takes its empty
/// surface and capacities from the mesh. InvalidArgument for bad corners or an opening that
/// differs from the scans' by more than `max_mismatch_m` at a corner (or its area by 5%).
absl::Status AttachMesh(const TriangleMesh& mesh, const Corners& corners_mesh,
                        const ModelConfig& config, ContainerModel& model,
                        double max_mismatch_m = 0.05, const StopToken& stop = {});

/// The returns a noiseless sensor at the origin sees of `mesh` (scan frame), at most one per
/// direction of a grid of `step_deg` covering it (coarser when more than `max_rays`).
Cloud CastMesh(const TriangleMesh& mesh, double step_deg, std::size_t max_rays);

/// The surface of `mesh` (container frame) seen from straight above `opening`, over `grid`:
/// each cell the mean of those of 4 x 4 samples that lie in the opening, each the highest mesh
/// point below the opening plane. Cells no sample hits keep NaN (a mesh with a hole there).
volume::EmptySurface MeshEmptySurface(const TriangleMesh& mesh, const Polygon2d& opening,
                                      const volume::Grid& grid);

}  // namespace soilvol::model
