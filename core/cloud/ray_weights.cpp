#include "core/cloud/ray_weights.hpp"

#include <algorithm>
#include <cmath>

#include "core/cloud/kd_tree.hpp"
#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"

namespace soilvol::cloud {
namespace {

// Heights seen at grazing incidence are precise only as far as the normal is right: cap the
// inverse variance at that of a floor seen from 30 deg.
constexpr double kMaxWeight = 4.0;

}  // namespace

std::vector<float> RayWeights(const Cloud& points, const Eigen::Vector3d& sensor_origin,
                              double noise_sigma_m, const RayWeightConfig& config,
                              const StopToken& stop) {
    std::vector<float> weights(points.size(), 0.0f);
    if (points.empty()) return weights;
    // Normals of the local surface, from neighbourhoods wide against the noise.
    const double radius = std::max(config.radius_m, config.noise_sigmas * noise_sigma_m);
    // One normal per voxel (of the voxel's centroid); each point takes its voxel's.
    const VoxelCentroids voxels = CentroidsOf(points, config.voxel_m);
    const Cloud& centroids = voxels.points;
    const LocalSurface surface =
        SmoothLocalSurface(centroids, voxels.counts, radius, kMinSurfaceNeighbors, stop);
    if (stop.StopRequested()) return weights;
    // SmoothLocalSurface keeps the centroids with neighbours, in order: map them back.
    std::vector<int64_t> normal_of(centroids.size(), -1);
    std::size_t missing = 0;
    for (std::size_t v = 0, s = 0; v < centroids.size(); ++v) {
        if (s < surface.sources.size() && surface.sources[s] == centroids[v]) {
            normal_of[v] = static_cast<int64_t>(s++);
        } else {
            ++missing;
        }
    }
    // A voxel too sparse for a normal of its own takes its nearest neighbour's.
    if (missing > 0 && !surface.sources.empty()) {
        const KdTree tree(surface.sources);
        for (std::size_t v = 0; v < centroids.size(); ++v) {
            if (normal_of[v] < 0) normal_of[v] = tree.Nearest(centroids[v]).first;
        }
    }
    const Eigen::Vector3f origin = sensor_origin.cast<float>();
    const auto n = static_cast<long>(points.size());
#pragma omp parallel for schedule(static)
    for (long i = 0; i < n; ++i) {
        const auto k = static_cast<std::size_t>(i);
        const int64_t j = normal_of[voxels.voxel_of[k]];
        if (j < 0) continue;
        const Eigen::Vector3f normal = surface.normals[static_cast<std::size_t>(j)];
        const Eigen::Vector3f ray = (points[k] - origin).normalized();
        const double nz2 = static_cast<double>(normal.z() * normal.z());
        const double rn = static_cast<double>(ray.dot(normal));
        const double v = nz2 / std::max(rn * rn, 1e-6);
        weights[k] = static_cast<float>(std::min(v, kMaxWeight));
    }
    return weights;
}

}  // namespace soilvol::cloud
