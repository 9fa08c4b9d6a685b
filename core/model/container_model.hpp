#pragma once

#include <cstddef>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "core/align/icp.hpp"
#include "core/cloud/preprocess.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/model/opening.hpp"
#include "core/model/thin_shell.hpp"
#include "core/volume/heightmap_volume.hpp"

namespace soilvol::model {

struct ModelConfig {
    cloud::PreprocessConfig preprocess;
    OpeningConfig opening;
    /// Empty points over the opening and up to this far above it belong to the inside (Fig. 6).
    double inside_above_m = 0.05;
    /// Alignment set: outside points, minus a band this wide around the opening below the rim
    /// (the inner walls that soil will cover), voxel-averaged at `alignment_voxel_m`.
    double wall_band_m = 0.05;
    double alignment_voxel_m = 0.03;  ///< one alignment point per voxel of this size
    /// Smoothing of the alignment set; must match AlignConfig's target_voxel_m and
    /// smoothing_radius_m, which treat each scan the same way.
    double smoothing_voxel_m = 0.03;
    double smoothing_radius_m = 0.08;  ///< at least; `smoothing_sigmas` noise sigmas when larger
    double smoothing_sigmas = 3.0;
    /// A sensor that scans in rows far apart (a spinning lidar's rings, cloud::
    /// MeasureAngularSampling) smooths over `row_gaps` gaps between its rows at the scan's
    /// median range, so that every neighbourhood spans rows (one row is a line: no normal), up
    /// to `max_smoothing_radius_m`; every later scan is smoothed as widely.
    double row_gaps = 1.25;
    double max_smoothing_radius_m = 0.32;
    /// Returns within this many noise sigmas of the container's structure (its surfaces outside
    /// the opening's column: rim, outer walls, linkage, high sides) are not contents.
    double structure_sigmas = 2.5;
    double min_structure_radius_m = 0.02;
    double max_structure_radius_m = 0.15;
    std::size_t min_inside_points = 30;
    std::size_t min_alignment_points = 30;
    /// > 0: the sensor's range noise [m], taken instead of the empty scan's (a virtual scan of
    /// a mesh has none).
    double noise_sigma_m = 0.0;
    volume::HeightmapConfig heightmap;  ///< used for the empty surface and the capacities
    ThinShellConfig shell;              ///< the inner face of walls seen only from outside
};

class ModelCache;

/// A part of the opening along one of its sides that no empty scan saw (the inside of a wall a
/// view hid, and the floor in its shadow), with what it leaves the struck capacity unsure of.
struct UnseenSide {
    int from_corner = 0, to_corner = 1;  ///< the side, by the corners as marked (0-3)
    double area_m2 = 0.0;                ///< of the opening, nearest this side, not seen
    double sigma_m3 = 0.0;               ///< its share of the struck capacity's 1-sigma
};

/// The container model (paper Sec. 3.2), built once from a scan of the empty container.
/// Clouds are in the container frame of `opening`.
struct ContainerModel {
    Opening opening;  ///< T_scan_container: the container in the empty scan's frame
    Cloud inside;     ///< empty points over the opening
    /// Per empty scan: its inside points clear of the structure, with ray weights and sensor.
    std::vector<WeightedCloud> cavity;
    Cloud structure;                  ///< smoothed empty surface outside the opening's column
    double structure_radius_m = 0.0;  ///< returns this near the structure are not contents
    double column_top_m = 0.05;       ///< contents: over the opening, below this height
    double smoothing_radius_m = 0.0;  ///< of the alignment set; each scan is smoothed alike
    Cloud alignment_points;           ///< outside points used for ICP
    Cloud alignment_normals;          ///< unit normals of alignment_points
    std::vector<WallPrior> walls;     ///< inner faces inferred from outside (thin shell)
    TriangleMesh mesh;     ///< the CAD surface when registered from one (container frame)
    double depth_m = 0.0;  ///< opening plane to the lowest empty-surface cell
    double struck_capacity_m3 = 0.0;      ///< empty surface to the opening plane
    double heaped_capacity_sae_m3 = 0.0;  ///< struck + 1:1 heap (SAE J296)
    double heaped_capacity_iso_m3 = 0.0;  ///< struck + 2:1 heap (ISO 7546)
    /// 1-sigma of struck_capacity_m3: the range of the empty surface no scan saw and the
    /// measured cells' misfit (SurfaceMap::misfit), each summed over the cells (one wall is one
    /// error), the thin-shell walls' thickness, the fits.
    double struck_capacity_sigma_m3 = 0.0;
    std::vector<UnseenSide> unseen;  ///< sides with unseen parts, the largest 1-sigma first
    double noise_sigma_m = 0.0;      ///< robust noise of the empty surface fit
    double observed_share = 0.0;     ///< of the opening's area, seen by the empty scans
    std::size_t scan_points = 0;     ///< after preprocessing
    std::size_t outside_points = 0;
    /// What estimates derive from the fields above and reuse (model_cache.hpp); set anew by
    /// every change through this header and by the codec; null: derived afresh on every call.
    std::shared_ptr<ModelCache> cache;
};

/// Builds the model from an empty scan (scan frame) and its 4 opening corners (scan frame,
/// ordered around the opening). InvalidArgument for bad corners; FailedPrecondition when too
/// few points fall inside or outside the opening; DeadlineExceeded or Cancelled, naming the
/// stage, once `stop` asks for it.
absl::StatusOr<ContainerModel> BuildContainerModel(const Cloud& empty_scan, const Corners& corners,
                                                   const ModelConfig& config,
                                                   const StopToken& stop = {});

/// The same from an empty scan several sensors took together: `empty_scan` is the first
/// sensor's cloud (its frame is the scan frame of `corners`), `more_sensors` the others, each in
/// its own frame with its pose in the scan frame. Each cloud is preprocessed from its own
/// sensor; the alignment set is drawn from all of them; each adds the inside it saw, weighted
/// along its own rays.
absl::StatusOr<ContainerModel> BuildContainerModel(const Cloud& empty_scan,
                                                   const std::vector<SensorCloud>& more_sensors,
                                                   const Corners& corners,
                                                   const ModelConfig& config,
                                                   const StopToken& stop = {});

/// Adds one more scan of the empty container (scan frame) in which the container stands at
/// `T_scan_container` (found by aligning the model to it): its returns fill what earlier scans
/// did not see, and the empty surface and capacities are computed anew. FailedPrecondition when
/// too few of its points lie inside; the model is then left as it was. DeadlineExceeded or
/// Cancelled once `stop` asks for it; the model may then be part-updated: discard it.
absl::Status AddEmptyScan(const Cloud& empty_scan, const Pose& T_scan_container,
                          const ModelConfig& config, ContainerModel& model,
                          const StopToken& stop = {});

/// The same for an empty scan several sensors took together (as BuildContainerModel takes it).
absl::Status AddEmptyScan(const Cloud& empty_scan, const std::vector<SensorCloud>& more_sensors,
                          const Pose& T_scan_container, const ModelConfig& config,
                          ContainerModel& model, const StopToken& stop = {});

/// Where the rays of a scan come from, in the container frame: the scan frame's origin mapped by
/// `T_scan_container`, when it lies above the opening plane (by a tenth of the opening's
/// smaller side at least) as a sensor that sees the inside must. A cloud whose origin is not
/// its sensor (a site frame, a merged cloud) is read as seen from straight above.
Eigen::Vector3d SensorInContainer(const Pose& T_scan_container, const Polygon2d& opening);

/// Where the model's contents can be (alignments leave returns there out).
align::ContentColumn ContentColumnOf(const ContainerModel& model);

/// Aligns the model's outside to `scan` (scan frame, preprocessed) from `initial`, smoothing the
/// scan at least as widely as the model's alignment set was and leaving its contents out. On a
/// `stop`, the pose reached so far, not converged (align::Align).
align::AlignResult AlignModel(const ContainerModel& model, const Cloud& scan, const Pose& initial,
                              const align::AlignConfig& config, const StopToken& stop = {});

/// The points of `points` (container frame) farther than the model's structure radius from its
/// structure, with their weights.
WeightedCloud RemoveStructure(const ContainerModel& model, const WeightedCloud& points);

/// The empty surface, capacities, depth and observed share of `model` computed anew from its
/// cavity, walls and mesh (after a change of any). DeadlineExceeded or Cancelled once `stop`
/// asks for it.
absl::Status UpdateCapacities(const ModelConfig& config, ContainerModel& model,
                              const StopToken& stop = {});

/// The empty container's surface over `grid`: the mesh's when the model has one; else fitted to
/// the empty scans' insides (cavity), raised to the walls the thin-shell prior infers.
absl::StatusOr<volume::EmptySurface> ModelEmptySurface(const ContainerModel& model,
                                                       const volume::Grid& grid,
                                                       const volume::HeightmapConfig& config,
                                                       const StopToken& stop = {});

/// Struck capacity [m^3] from an empty surface: sum over cells of area x depth below z = 0.
/// Heaped capacity adds slope x the integral of the distance to the opening edge:
///   SAE J296 (1:1):  V_heaped = V_struck + 1.0 * int_A d(x, y) dA
///   ISO 7546 (2:1):  V_heaped = V_struck + 0.5 * int_A d(x, y) dA
/// (for an L x W rectangle, int_A d dA = W^2 L / 4 - W^3 / 12).
double HeapVolume(const Polygon2d& opening, double slope);

}  // namespace soilvol::model
