#include "core/model/container_model.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/status_macros.hpp"
#include "core/volume/surface_estimator.hpp"

namespace soilvol::model {
namespace {

// Fig. 6: inside = over the opening and below it (plus a little above); the rest is outside.
void SplitInsideOutside(const Cloud& points, const Opening& opening, const ModelConfig& config,
                        Cloud& inside, Cloud& outside) {
    for (const auto& p : points) {
        const bool over = opening.polygon.Contains(p.head<2>().cast<double>());
        if (over && static_cast<double>(p.z()) <= config.inside_above_m) {
            inside.push_back(p);
        } else {
            outside.push_back(p);
        }
    }
}

// Points in the opening's column (or within `band_m` of it) below the rim are the inside and
// the inner walls seen through noise; soil covers them, so they stay out of the alignment set.
bool InAlignmentSet(const Eigen::Vector3f& p, const Opening& opening, double band_m) {
    const Eigen::Vector2d xy = p.head<2>().cast<double>();
    const bool near_column =
        opening.polygon.Contains(xy) || opening.polygon.DistanceToBoundary(xy) < band_m;
    return !(near_column && static_cast<double>(p.z()) < -band_m);
}

// Near-vertical surfaces of the container, inside the opening's column or around it (inner
// and outer walls). Horizontal rims and sloped walls are not structure: the heightmap holds
// them, and the lowest-layer rule of the surface fit keeps a rim's noise off the floor.
Cloud StructurePoints(const Cloud& inside, const Cloud& outside, const ModelConfig& config,
                      double radius_m) {
    Cloud all = inside;
    all.insert(all.end(), outside.begin(), outside.end());
    const cloud::LocalSurface local =
        cloud::SmoothLocalSurface(cloud::VoxelDownsample(all, config.smoothing_voxel_m), radius_m);
    const auto max_nz =
        static_cast<float>(std::cos(config.wall_min_slope_deg * 3.14159265358979 / 180.0));
    Cloud structure;
    for (std::size_t i = 0; i < local.points.size(); ++i) {
        if (std::abs(local.normals[i].z()) < max_nz) structure.push_back(local.points[i]);
    }
    return structure;
}

// Columns near structure between the lowest inner point and the highest heap; what lies below
// the container (its underside, the ground) does not mask the column above it.
StructureMask MakeMask(const Cloud& structure, const Opening& opening, double radius_m,
                       double depth_m, double max_heap_slope) {
    const Eigen::Vector2d margin(radius_m, radius_m);
    const double top =
        max_heap_slope * 0.5 * (opening.polygon.Max() - opening.polygon.Min()).minCoeff();
    return StructureMask(structure, radius_m, opening.polygon.Min() - margin,
                         opening.polygon.Max() + margin, -depth_m - radius_m, top + radius_m);
}

double LowestZ(const Cloud& points) {
    std::vector<float> z;
    for (const auto& p : points) z.push_back(p.z());
    const auto k = static_cast<long>(0.002 * static_cast<double>(z.size()));
    std::nth_element(z.begin(), z.begin() + k, z.end());
    return static_cast<double>(z[static_cast<std::size_t>(k)]);
}

}  // namespace

double HeapVolume(const Polygon2d& opening, double slope) {
    return slope * opening.DistanceIntegral();
}

absl::StatusOr<ContainerModel> BuildContainerModel(const Cloud& empty_scan, const Corners& corners,
                                                   const ModelConfig& config) {
    ContainerModel model;
    const cloud::PreprocessResult pre = cloud::Preprocess(empty_scan, config.preprocess);
    model.scan_points = pre.points.size();
    SOILVOL_ASSIGN_OR_RETURN(model.opening, MakeOpening(corners, pre.points, config.opening));
    const Cloud points = ToContainerFrame(pre.points, model.opening.T_scan_container);
    Cloud outside;
    SplitInsideOutside(points, model.opening, config, model.inside, outside);
    model.outside_points = outside.size();
    if (model.inside.size() < config.min_inside_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", model.inside.size(), " points of the empty scan lie inside the opening (need ",
            config.min_inside_points, "): check the corners and that the inside is visible"));
    }
    // The whole scan smoothed as the pipeline smooths each new scan before ICP (AlignConfig),
    // so that a mean near the rim sees the same surfaces in both; then selected and thinned.
    const cloud::LocalSurface surface = cloud::SmoothLocalSurface(
        cloud::VoxelDownsample(points, config.smoothing_voxel_m), config.smoothing_radius_m);
    Cloud selected, selected_normals;
    for (std::size_t i = 0; i < surface.points.size(); ++i) {
        if (!InAlignmentSet(surface.sources[i], model.opening, config.wall_band_m)) continue;
        selected.push_back(surface.points[i]);
        selected_normals.push_back(surface.normals[i]);
    }
    const cloud::VoxelGrid thin(selected, config.alignment_voxel_m);
    for (std::size_t v = 0; v < thin.NumVoxels(); ++v) {
        const uint32_t i = thin.Order()[thin.Range(v).first];
        model.alignment_points.push_back(selected[i]);
        model.alignment_normals.push_back(selected_normals[i]);
    }
    if (model.alignment_points.size() < config.min_alignment_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", model.alignment_points.size(), " alignment points outside the opening (need ",
            config.min_alignment_points, "): the container's outside must be visible to align it"));
    }
    // Sec. 3.2: the empty surface; struck capacity is the volume between it and the opening.
    const double cell_m = config.heightmap.cell_m > 0.0
                              ? config.heightmap.cell_m
                              : volume::AutomaticCellSize(model.inside.size(),
                                                          model.opening.polygon, config.heightmap);
    const volume::Grid grid = volume::MakeGrid(model.opening.polygon, cell_m);
    SOILVOL_ASSIGN_OR_RETURN(const volume::SurfaceMap rough,
                             volume::EstimateSurface(grid, model.inside, config.heightmap.surface));
    const double radius = std::clamp(config.structure_sigmas * rough.noise_sigma_m,
                                     config.min_structure_radius_m, config.max_structure_radius_m);
    model.structure =
        StructurePoints(model.inside, outside, config, std::max(radius, config.smoothing_radius_m));
    model.mask = MakeMask(model.structure, model.opening, radius, -LowestZ(model.inside),
                          config.heightmap.max_heap_slope);
    model.floor = model.mask.Filter(model.inside);
    if (model.floor.size() < config.min_inside_points) {
        return absl::FailedPreconditionError(
            absl::StrCat("only ", model.floor.size(),
                         " points of the empty scan lie on its floor clear of the walls (need ",
                         config.min_inside_points, "): the floor must be visible"));
    }
    SOILVOL_ASSIGN_OR_RETURN(const volume::SurfaceMap empty,
                             volume::EstimateSurface(grid, model.floor, config.heightmap.surface));
    double lowest = 0.0;
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        if (grid.weight[k] <= 0.0) continue;
        model.struck_capacity_m3 += grid.weight[k] * std::max(0.0, -empty.height[k]);
        lowest = std::min(lowest, empty.height[k]);
    }
    model.depth_m = -lowest;
    model.noise_sigma_m = empty.noise_sigma_m;
    model.heaped_capacity_sae_m3 =
        model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 1.0);
    model.heaped_capacity_iso_m3 =
        model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 0.5);
    return model;
}

}  // namespace soilvol::model
