#pragma once

#include <functional>
#include <memory>

#include "absl/status/statusor.h"
#include "core/cloud/ray_weights.hpp"
#include "core/common/polygon.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/volume/surface_estimator.hpp"
#include "core/volume/volume_result.hpp"

namespace soilvol::volume {

/// soilvol's estimator: the empty surface and the scan's surface fitted alike (ray-weighted,
/// symmetric robust local planes), holes filled by Cauchy-weighted planes through the measured
/// cells around them, signed integration (noise is never clipped cell by cell), exact cell
/// areas. See core/volume/README.md.
struct HeightmapConfig {
    double cell_m = 0.0;                   ///< grid cell side; 0 = automatic from point density
    double target_points_per_cell = 16.0;  ///< density target of the automatic cell size
    double min_cell_m = 0.02;
    double max_cell_fraction = 0.25;  ///< automatic cells stay below this share of the opening
    /// Automatic cells grow until the opening's bounding box holds at most this many (memory:
    /// about 200 bytes a cell for an estimate); explicit cells beyond it are refused.
    double max_cells = 250000.0;
    double max_heap_slope = 1.0;         ///< scan points above a heap this steep are ignored
    double column_margin_m = 0.15;       ///< points this far below the empty surface are ignored
    cloud::RayWeightConfig ray_weights;  ///< how the points' height weights are computed
    SurfaceConfig surface;
};

/// Cell size [m] the automatic rule picks for `points_in_opening` points over the opening: the
/// density target's size, rounded to a step of 2^(1/8) from min_cell_m (so that scans of one
/// container from one sensor share a grid, and its empty surface), within the limits.
double AutomaticCellSize(std::size_t points_in_opening, const Polygon2d& opening,
                         const HeightmapConfig& config);

/// The points (container frame; with their weights when `weights` is not empty) that can belong
/// to the contents: over the opening, no deeper than the empty surface minus the margin, no
/// higher than the steepest heap; seen from `sensor`. Reads the scan in place: no copy of it.
WeightedCloud SelectColumn(const Cloud& points, const std::vector<float>& weights,
                           const Eigen::Vector3d& sensor, const Polygon2d& opening,
                           double empty_min_z, const HeightmapConfig& config);

/// The empty container's surface over a grid. Cells no empty scan saw well enough lie between
/// the plane their neighbours continue (or the returns they hold, if higher) and the lowest
/// empty-scan ray above them; they take the lower bound and a 1-sigma of the range / sqrt(12).
struct EmptySurface {
    SurfaceMap map;
    std::vector<double> unobserved_sigma_m;  ///< per cell; 0 where observed
    double area_m2 = 0.0;                    ///< of the opening
    double observed_area_m2 = 0.0;           ///< of the cells the empty scans saw
};

/// FailedPrecondition when no cell of `empty` (container frame) can be fitted; DeadlineExceeded
/// or Cancelled once `stop` asks for it.
absl::StatusOr<EmptySurface> EstimateEmptySurface(const Grid& grid,
                                                  const std::vector<WeightedCloud>& empty,
                                                  const HeightmapConfig& config,
                                                  const StopToken& stop = {});

/// The empty container as HeightmapVolume reads it: how deep its inside reaches, and its
/// surface over any grid (computed on demand, or taken from a cache).
struct EmptySide {
    double min_z = 0.0;  ///< a low quantile of the inside's heights [m]
    std::function<absl::StatusOr<std::shared_ptr<const EmptySurface>>(const Grid&)> surface;
};

/// The lowest height of the empty scans' inside points, robust to a few strays.
double EmptyMinZ(const std::vector<WeightedCloud>& empty_inside);

/// Soil volume between the empty surface and the scan's surface, both in the container frame
/// with ray weights. `scan` holds one cloud per sensor, each with its sensor: the soil surface
/// is fitted to all their returns, a cell counts as seen when any sensor saw it, and a hidden
/// cell is bounded by the lowest ray of any sensor above it. FailedPrecondition when either
/// surface has no measurable cell; DeadlineExceeded or Cancelled once `stop` asks for it
/// (`empty` takes care of its own).
absl::StatusOr<VolumeResult> HeightmapVolume(const EmptySide& empty,
                                             const std::vector<WeightedCloud>& scan,
                                             const Polygon2d& opening,
                                             const HeightmapConfig& config,
                                             const StopToken& stop = {});

/// The same with the empty surface computed from the empty scans' inside points (container
/// frame, with ray weights); `empty_inside` must outlive the call only.
absl::StatusOr<VolumeResult> HeightmapVolume(const std::vector<WeightedCloud>& empty_inside,
                                             const std::vector<WeightedCloud>& scan,
                                             const Polygon2d& opening,
                                             const HeightmapConfig& config,
                                             const StopToken& stop = {});

}  // namespace soilvol::volume
