#include "core/model/container_model.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/cloud/kd_tree.hpp"
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

// Outside points near the opening's column and below the rim are inner walls seen through
// noise; soil covers them, so they stay out of the alignment set.
Cloud AlignmentCandidates(const Cloud& outside, const Opening& opening, double band_m) {
    Cloud kept;
    for (const auto& p : outside) {
        const Eigen::Vector2d xy = p.head<2>().cast<double>();
        const bool near_column =
            opening.polygon.Contains(xy) || opening.polygon.DistanceToBoundary(xy) < band_m;
        if (near_column && static_cast<double>(p.z()) < -band_m) continue;
        kept.push_back(p);
    }
    return kept;
}

// PCA normals of `targets` from the neighbours in `points` within `radius_m`.
Cloud EstimateNormals(const Cloud& targets, const Cloud& points, double radius_m) {
    const cloud::KdTree tree(points);
    Cloud normals(targets.size(), Eigen::Vector3f::UnitZ());
    for (std::size_t i = 0; i < targets.size(); ++i) {
        const auto found = tree.Radius(targets[i], radius_m);
        if (found.size() < 3) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& f : found) mean += points[f.first].cast<double>();
        mean /= static_cast<double>(found.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& f : found) {
            const Eigen::Vector3d d = points[f.first].cast<double>() - mean;
            cov += d * d.transpose();
        }
        normals[i] = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0).cast<float>();
    }
    return normals;
}

}  // namespace

double HeapVolume(const Polygon2d& opening, double slope) { return slope * opening.DistanceIntegral(); }

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
    const Cloud candidates = AlignmentCandidates(outside, model.opening, config.wall_band_m);
    model.alignment_points = cloud::VoxelDownsample(candidates, config.alignment_voxel_m);
    if (model.alignment_points.size() < config.min_alignment_points) {
        return absl::FailedPreconditionError(absl::StrCat(
            "only ", model.alignment_points.size(), " alignment points outside the opening (need ",
            config.min_alignment_points, "): the container's outside must be visible to align it"));
    }
    model.alignment_normals = EstimateNormals(model.alignment_points, candidates, config.normal_radius_m);
    // Sec. 3.2: the empty surface; struck capacity is the volume between it and the opening.
    const double cell_m = config.heightmap.cell_m > 0.0
                              ? config.heightmap.cell_m
                              : volume::AutomaticCellSize(model.inside.size(), model.opening.polygon,
                                                          config.heightmap);
    const volume::Grid grid = volume::MakeGrid(model.opening.polygon, cell_m);
    SOILVOL_ASSIGN_OR_RETURN(const volume::SurfaceMap empty,
                             volume::EstimateSurface(grid, model.inside, config.heightmap.surface));
    double lowest = 0.0;
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        if (grid.weight[k] <= 0.0) continue;
        model.struck_capacity_m3 += grid.weight[k] * std::max(0.0, -empty.height[k]);
        lowest = std::min(lowest, empty.height[k]);
    }
    model.depth_m = -lowest;
    model.noise_sigma_m = empty.noise_sigma_m;
    model.heaped_capacity_sae_m3 = model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 1.0);
    model.heaped_capacity_iso_m3 = model.struck_capacity_m3 + HeapVolume(model.opening.polygon, 0.5);
    return model;
}

}  // namespace soilvol::model
