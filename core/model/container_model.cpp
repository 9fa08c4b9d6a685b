#include "core/model/container_model.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/cloud/angular_sampling.hpp"
#include "core/cloud/kd_tree.hpp"
#include "core/cloud/local_surface.hpp"
#include "core/cloud/ray_weights.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/statistics.hpp"
#include "core/common/status_macros.hpp"
#include "core/model/mesh_model.hpp"
#include "core/model/model_cache.hpp"
#include "core/model/thin_shell.hpp"
#include "core/volume/surface_estimator.hpp"

namespace soilvol::model {
namespace {

// Fig. 6: inside = over the opening and below it (plus a little above); the rest is outside.
void SplitInsideOutside(const Cloud& points, const Eigen::Vector3d& sensor, const Opening& opening,
                        const ModelConfig& config, Cloud& inside, Cloud& outside) {
    for (const auto& p : points) {
        const bool over = opening.polygon.Contains(p.head<2>().cast<double>());
        if (over && static_cast<double>(p.z()) <= config.inside_above_m &&
            EntersThroughOpening(sensor, p, opening.polygon)) {
            inside.push_back(p);
        } else {
            outside.push_back(p);
        }
    }
}

// The smoothed empty surface outside the opening's column (or above the opening): rim, outer
// walls, linkage, high sides. No slope decides it: a wall inside the column, at any angle, is
// the empty surface; a wall on the column's boundary lies half outside and so marks the returns
// that noise spread into the column.
Cloud StructurePoints(const Cloud& points, const Opening& opening, const ModelConfig& config,
                      double radius_m, double depth_m, const StopToken& stop) {
    const cloud::VoxelCentroids voxels = cloud::CentroidsOf(points, config.smoothing_voxel_m);
    const cloud::LocalSurface local = cloud::SmoothLocalSurface(
        voxels.points, voxels.counts, radius_m, cloud::kMinSurfaceNeighbors, stop);
    const double top = config.heightmap.max_heap_slope * 0.5 *
                       (opening.polygon.Max() - opening.polygon.Min()).minCoeff();
    // Each voxel is classified by its smoothed position (noise averaged out) and kept at its
    // own position: a smoothed edge shrinks away from the edge, the voxels do not.
    Cloud structure;
    for (std::size_t i = 0; i < local.points.size(); ++i) {
        const Eigen::Vector3f& m = local.points[i];
        const double z = static_cast<double>(m.z());
        if (z < -depth_m - radius_m || z > top + radius_m) continue;
        const Eigen::Vector2d xy = m.head<2>().cast<double>();
        const bool over = opening.polygon.Contains(xy);
        if (over && z <= config.inside_above_m) continue;
        if (!over && opening.polygon.DistanceToBoundary(xy) > 2.0 * radius_m + 0.1) continue;
        structure.push_back(local.sources[i]);
    }
    return structure;
}

double LowestZ(const Cloud& points) {
    std::vector<float> z;
    z.reserve(points.size());
    for (const auto& p : points) z.push_back(p.z());
    return QuantileInPlace(z, 0.002);
}

// The grid of the model's own figures: the automatic cell for the inside's density.
double ModelCell(const ContainerModel& model, const ModelConfig& config) {
    return config.heightmap.cell_m > 0.0
               ? config.heightmap.cell_m
               : volume::AutomaticCellSize(model.inside.empty() ? 1000 : model.inside.size(),
                                           model.opening.polygon, config.heightmap);
}

// The noise of the empty scan (robust residuals of a first surface fit over the opening), and
// the radii it sets: a mean over 2 sigmas keeps most of a point's noise, one over 3 a third.
absl::Status MeasureNoise(const Cloud& points, const ModelConfig& config, ContainerModel& model,
                          const StopToken& stop) {
    Cloud inside, outside;
    SplitInsideOutside(points,
                       SensorInContainer(model.opening.T_scan_container, model.opening.polygon),
                       model.opening, config, inside, outside);
    model.outside_points = outside.size();
    if (inside.size() < config.min_inside_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", inside.size(), " points of the empty scan lie inside the opening (need ",
            config.min_inside_points, "): check the corners and that the inside is visible"));
    }
    const double cell_m =
        config.heightmap.cell_m > 0.0
            ? config.heightmap.cell_m
            : volume::AutomaticCellSize(inside.size(), model.opening.polygon, config.heightmap);
    SOILVOL_ASSIGN_OR_RETURN(
        const volume::SurfaceMap rough,
        volume::EstimateSurface(volume::MakeGrid(model.opening.polygon, cell_m), inside, {},
                                config.heightmap.surface, stop));
    model.noise_sigma_m = config.noise_sigma_m > 0.0 ? config.noise_sigma_m : rough.noise_sigma_m;
    model.smoothing_radius_m =
        std::max(config.smoothing_radius_m, config.smoothing_sigmas * model.noise_sigma_m);
    // Noise sigmas, plus half a voxel: the structure is kept as voxel centroids.
    model.structure_radius_m =
        std::clamp(config.structure_sigmas * model.noise_sigma_m + 0.5 * config.smoothing_voxel_m,
                   config.min_structure_radius_m, config.max_structure_radius_m);
    return absl::OkStatus();
}

}  // namespace

Eigen::Vector3d SensorInContainer(const Pose& T_scan_container, const Polygon2d& opening) {
    const Eigen::Vector3d origin = T_scan_container.inverse().translation();
    const Eigen::Vector2d extent = opening.Max() - opening.Min();
    if (origin.z() >= 0.1 * extent.minCoeff()) return origin;
    const Eigen::Vector2d centre = 0.5 * (opening.Min() + opening.Max());
    return {centre.x(), centre.y(), 1000.0 * std::max(1.0, extent.maxCoeff())};
}

align::ContentColumn ContentColumnOf(const ContainerModel& model) {
    // The inner walls' band reaches 3 noise sigmas past the rim's own returns.
    const double band = std::max(model.column_top_m, 3.0 * model.noise_sigma_m);
    return {model.opening.polygon, model.column_top_m, band, 0.0};
}

align::AlignResult AlignModel(const ContainerModel& model, const Cloud& scan, const Pose& initial,
                              const align::AlignConfig& config, const StopToken& stop) {
    align::AlignConfig align = config;
    align.smoothing_radius_m = std::max(align.smoothing_radius_m, model.smoothing_radius_m);
    const align::ContentColumn column = ContentColumnOf(model);
    return align::Align(model.alignment_points, model.alignment_normals, scan, initial, align,
                        &column, stop);
}

WeightedCloud RemoveStructure(const ContainerModel& model, const WeightedCloud& points) {
    if (model.structure.empty() || model.structure_radius_m <= 0.0) return points;
    std::unique_ptr<StructureIndex> own;
    const StructureIndex& index = model.cache ? model.cache->Structure(model)
                                              : *(own = std::make_unique<StructureIndex>(model));
    WeightedCloud kept;
    kept.sensor = points.sensor;
    kept.points.reserve(points.points.size());
    for (std::size_t i = 0; i < points.points.size(); ++i) {
        if (index.Near(points.points[i])) continue;
        kept.points.push_back(points.points[i]);
        if (!points.weights.empty()) kept.weights.push_back(points.weights[i]);
    }
    return kept;
}

absl::StatusOr<volume::EmptySurface> ModelEmptySurface(const ContainerModel& model,
                                                       const volume::Grid& grid,
                                                       const volume::HeightmapConfig& config,
                                                       const StopToken& stop) {
    if (!model.mesh.triangles.empty()) {
        SOILVOL_RETURN_IF_ERROR(stop.Check("empty surface of the mesh"));
        return MeshEmptySurface(model.mesh, model.opening.polygon, grid);
    }
    SOILVOL_ASSIGN_OR_RETURN(volume::EmptySurface empty,
                             volume::EstimateEmptySurface(grid, model.cavity, config, stop));
    ApplyWallPriors(model.walls, model.opening.polygon, grid, empty);
    return empty;
}

double HeapVolume(const Polygon2d& opening, double slope) {
    return slope * opening.DistanceIntegral();
}

namespace {

// The model's alignment set (Sec. 3.3): the scan smoothed as the pipeline smooths each new scan
// before ICP (AlignConfig), so that a mean near the rim sees the same surfaces in both; then
// selected and thinned.
absl::Status MakeAlignmentSet(const Cloud& points, const ModelConfig& config, ContainerModel& model,
                              const StopToken& stop) {
    const align::ContentColumnIndex column(ContentColumnOf(model));
    Cloud outside;
    for (const auto& p : points) {
        if (!column.Holds(p.cast<double>())) outside.push_back(p);
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check("alignment set"));
    const cloud::VoxelCentroids voxels = cloud::CentroidsOf(outside, config.smoothing_voxel_m);
    const cloud::LocalSurface surface = cloud::SmoothLocalSurface(
        voxels.points, voxels.counts, model.smoothing_radius_m, cloud::kMinSurfaceNeighbors, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("alignment set"));
    const Cloud& selected = surface.points;
    const Cloud& selected_normals = surface.normals;
    const cloud::VoxelGrid thin(selected, config.alignment_voxel_m);
    for (std::size_t v = 0; v < thin.NumVoxels(); ++v) {
        const uint32_t i = thin.Order()[thin.Range(v).first];
        model.alignment_points.push_back(selected[i]);
        model.alignment_normals.push_back(selected_normals[i]);
    }
    return absl::OkStatus();
}

// One empty scan's share of the model: its inside, its structure, its cavity with ray weights.
absl::Status AddCavity(const Cloud& points, const Eigen::Vector3d& sensor,
                       const ModelConfig& config, ContainerModel& model, const StopToken& stop) {
    Cloud inside, outside;
    SplitInsideOutside(points, sensor, model.opening, config, inside, outside);
    // What this view saw of the walls' outside stands for the inside it could not see.
    MergeWalls(InnerFaceFromOutside(outside, sensor, model.opening.polygon, config.shell),
               model.walls);
    SOILVOL_RETURN_IF_ERROR(stop.Check("structure"));
    const Cloud structure =
        StructurePoints(points, model.opening, config,
                        std::max(model.structure_radius_m, config.smoothing_radius_m),
                        -LowestZ(inside.empty() ? points : inside), stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("structure"));
    model.structure.insert(model.structure.end(), structure.begin(), structure.end());
    WeightedCloud cavity = RemoveStructure(model, WeightedCloud{inside, {}, sensor});
    if (cavity.points.size() < config.min_inside_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", cavity.points.size(), " points of empty scan ", model.cavity.size() + 1,
            " lie inside the container clear of its rim and walls (need ", config.min_inside_points,
            "): the inside must be visible"));
    }
    cavity.weights = cloud::RayWeights(cavity.points, sensor, model.noise_sigma_m,
                                       config.heightmap.ray_weights, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("ray weights"));
    model.inside.insert(model.inside.end(), inside.begin(), inside.end());
    model.cavity.push_back(std::move(cavity));
    return absl::OkStatus();
}

// The opening's side nearest `xy`: the polygon's edge index.
int NearestSide(const Polygon2d& polygon, const Eigen::Vector2d& xy) {
    const auto& v = polygon.Vertices();
    int best = 0;
    double best_d = 1e300;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const Eigen::Vector2d a = v[i], b = v[(i + 1) % v.size()];
        const double t =
            std::clamp((xy - a).dot(b - a) / std::max((b - a).squaredNorm(), 1e-12), 0.0, 1.0);
        const double d = (a + t * (b - a) - xy).norm();
        if (d < best_d) best_d = d, best = static_cast<int>(i);
    }
    return best;
}

// The struck capacity's 1-sigma: unseen cells' ranges and measured cells' misfits summed
// linearly (a wall is one error), the prior walls' thickness over their height and length, the
// fits' variances (windows counted once); and the sides the unseen parts lie along.
void SetCapacitySigma(const volume::Grid& grid, const volume::EmptySurface& empty,
                      ContainerModel& model) {
    const Polygon2d& polygon = model.opening.polygon;
    const std::size_t sides = polygon.Vertices().size();
    std::vector<UnseenSide> per_side(sides);
    const double window = static_cast<double>(empty.map.window_cells * empty.map.window_cells);
    double fit_variance = 0.0, linear = 0.0;
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        const double w = grid.weight[k];
        if (w <= 0.0) continue;
        if (std::isfinite(empty.map.variance[k]))
            fit_variance += w * w * window * empty.map.variance[k];
        // What a measured cell's plane does not follow: one wall, one error.
        if (k < empty.map.misfit.size() && std::isfinite(empty.map.misfit[k]))
            linear += w * empty.map.misfit[k];
        const double s = empty.unobserved_sigma_m[k];
        if (s <= 0.0) continue;
        linear += w * s;
        UnseenSide& side = per_side[static_cast<std::size_t>(NearestSide(polygon, grid.anchor[k]))];
        side.area_m2 += w;
        side.sigma_m3 += w * s;
    }
    for (const WallPrior& wall : model.walls) {
        if (wall.profile.empty() || static_cast<std::size_t>(wall.edge) >= sides) continue;
        const auto& v = polygon.Vertices();
        const double length = (v[(static_cast<std::size_t>(wall.edge) + 1) % sides] -
                               v[static_cast<std::size_t>(wall.edge)])
                                  .norm();
        const double term = wall.thickness_sigma_m * -wall.profile.back().x() * length;
        linear += term;
        per_side[static_cast<std::size_t>(wall.edge)].sigma_m3 += term;
    }
    model.struck_capacity_sigma_m3 = std::hypot(std::sqrt(fit_variance), linear);
    model.unseen.clear();
    for (std::size_t e = 0; e < sides; ++e) {
        UnseenSide side = per_side[e];
        if (side.area_m2 <= 0.0 && side.sigma_m3 <= 0.0) continue;
        side.from_corner = model.opening.corner_of_vertex[e % 4];
        side.to_corner = model.opening.corner_of_vertex[(e + 1) % 4];
        model.unseen.push_back(side);
    }
    std::sort(model.unseen.begin(), model.unseen.end(),
              [](const UnseenSide& a, const UnseenSide& b) { return a.sigma_m3 > b.sigma_m3; });
}

}  // namespace

// Sec. 3.2: the empty surface from every empty scan; the struck capacity is the volume between
// it and the opening.
absl::Status UpdateCapacities(const ModelConfig& config, ContainerModel& model,
                              const StopToken& stop) {
    model.cache = std::make_shared<ModelCache>();
    SOILVOL_RETURN_IF_ERROR(stop.Check("empty surface"));
    const volume::Grid grid = volume::MakeGrid(model.opening.polygon, ModelCell(model, config));
    SOILVOL_ASSIGN_OR_RETURN(const volume::EmptySurface empty,
                             ModelEmptySurface(model, grid, config.heightmap, stop));
    model.observed_share = empty.area_m2 > 0.0 ? empty.observed_area_m2 / empty.area_m2 : 0.0;
    model.struck_capacity_m3 = 0.0;
    double lowest = 0.0;
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        if (grid.weight[k] <= 0.0) continue;
        model.struck_capacity_m3 += grid.weight[k] * std::max(0.0, -empty.map.height[k]);
        lowest = std::min(lowest, empty.map.height[k]);
    }
    model.depth_m = -lowest;
    SetCapacitySigma(grid, empty, model);
    model.heaped_capacity_sae_m3 =
        model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 1.0);
    model.heaped_capacity_iso_m3 =
        model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 0.5);
    return absl::OkStatus();
}

absl::StatusOr<ContainerModel> BuildContainerModel(const Cloud& empty_scan, const Corners& corners,
                                                   const ModelConfig& config,
                                                   const StopToken& stop) {
    return BuildContainerModel(empty_scan, {}, corners, config, stop);
}

namespace {

// Each sensor's cloud of one empty scan, preprocessed from where it stood, in the container
// frame (the container at `T_scan_container` in the scan frame), with that sensor's position
// there; the first is the scan frame's sensor's, `first` (preprocessed already).
struct SensorPoints {
    Cloud points;
    Eigen::Vector3d sensor;
    double row_gap_m = 0.0;  ///< between the sensor's rows at the median range; 0: no rows
};

// The gap between a sensor's rows of returns at the median range, from its own-frame points
// (the sensor at the origin); 0 when it does not scan in rows.
double RowGap(const Cloud& own_frame) {
    const cloud::AngularSampling sampling =
        cloud::MeasureAngularSampling(own_frame, Eigen::Vector3d::Zero());
    if (!sampling.rows) return 0.0;
    std::vector<float> range;
    range.reserve(own_frame.size());
    for (const auto& p : own_frame) range.push_back(p.norm());
    return QuantileInPlace(range, 0.5) * sampling.across_rad;
}

// Rows of returns far apart (a spinning lidar's rings) widen the smoothing until every
// neighbourhood spans rows: within one row a neighbourhood is a line, whose normal is
// arbitrary and matches nothing.
void WidenSmoothingToRows(const std::vector<SensorPoints>& sensors, const ModelConfig& config,
                          ContainerModel& model) {
    for (const SensorPoints& sensor : sensors) {
        model.smoothing_radius_m =
            std::max(model.smoothing_radius_m,
                     std::min(config.max_smoothing_radius_m, config.row_gaps * sensor.row_gap_m));
    }
}

absl::StatusOr<std::vector<SensorPoints>> EmptyScanInContainer(
    const Cloud& first, const std::vector<SensorCloud>& more_sensors, const Pose& T_scan_container,
    const ModelConfig& config, const Polygon2d& opening, const StopToken& stop) {
    std::vector<SensorPoints> out;
    out.reserve(1 + more_sensors.size());
    out.push_back({ToContainerFrame(first, T_scan_container),
                   SensorInContainer(T_scan_container, opening), RowGap(first)});
    for (const SensorCloud& more : more_sensors) {
        const cloud::PreprocessResult pre = cloud::Preprocess(more.points, config.preprocess, stop);
        const Pose T_sensor_container = more.T_scan_sensor.inverse() * T_scan_container;
        out.push_back({ToContainerFrame(pre.points, T_sensor_container),
                       SensorInContainer(T_sensor_container, opening), RowGap(pre.points)});
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check("preprocessing of the empty scan"));
    return out;
}

absl::Status AddCavities(const std::vector<SensorPoints>& sensors, const ModelConfig& config,
                         ContainerModel& model, const StopToken& stop) {
    for (const SensorPoints& sensor : sensors) {
        SOILVOL_RETURN_IF_ERROR(AddCavity(sensor.points, sensor.sensor, config, model, stop));
    }
    return UpdateCapacities(config, model, stop);
}

}  // namespace

absl::StatusOr<ContainerModel> BuildContainerModel(const Cloud& empty_scan,
                                                   const std::vector<SensorCloud>& more_sensors,
                                                   const Corners& corners,
                                                   const ModelConfig& config,
                                                   const StopToken& stop) {
    ContainerModel model;
    const cloud::PreprocessResult pre = cloud::Preprocess(empty_scan, config.preprocess, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("preprocessing of the empty scan"));
    SOILVOL_ASSIGN_OR_RETURN(model.opening, MakeOpening(corners, pre.points, config.opening));
    model.column_top_m = config.inside_above_m;
    SOILVOL_ASSIGN_OR_RETURN(
        const std::vector<SensorPoints> sensors,
        EmptyScanInContainer(pre.points, more_sensors, model.opening.T_scan_container, config,
                             model.opening.polygon, stop));
    for (const SensorPoints& sensor : sensors) model.scan_points += sensor.points.size();
    SOILVOL_RETURN_IF_ERROR(stop.Check("noise of the empty scan"));
    SOILVOL_RETURN_IF_ERROR(MeasureNoise(sensors[0].points, config, model, stop));
    WidenSmoothingToRows(sensors, config, model);
    Cloud all;
    for (std::size_t i = 1; i < sensors.size(); ++i) {
        if (all.empty()) all = sensors[0].points;
        all.insert(all.end(), sensors[i].points.begin(), sensors[i].points.end());
    }
    SOILVOL_RETURN_IF_ERROR(
        MakeAlignmentSet(sensors.size() == 1 ? sensors[0].points : all, config, model, stop));
    if (model.alignment_points.size() < config.min_alignment_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", model.alignment_points.size(), " alignment points outside the opening (need ",
            config.min_alignment_points, "): the container's outside must be visible to align it"));
    }
    SOILVOL_RETURN_IF_ERROR(AddCavities(sensors, config, model, stop));
    return model;
}

absl::Status AddEmptyScan(const Cloud& empty_scan, const Pose& T_scan_container,
                          const ModelConfig& config, ContainerModel& model, const StopToken& stop) {
    return AddEmptyScan(empty_scan, {}, T_scan_container, config, model, stop);
}

absl::Status AddEmptyScan(const Cloud& empty_scan, const std::vector<SensorCloud>& more_sensors,
                          const Pose& T_scan_container, const ModelConfig& config,
                          ContainerModel& model, const StopToken& stop) {
    const cloud::PreprocessResult pre = cloud::Preprocess(empty_scan, config.preprocess, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check("preprocessing of the empty scan"));
    SOILVOL_ASSIGN_OR_RETURN(const std::vector<SensorPoints> sensors,
                             EmptyScanInContainer(pre.points, more_sensors, T_scan_container,
                                                  config, model.opening.polygon, stop));
    return AddCavities(sensors, config, model, stop);
}

}  // namespace soilvol::model
