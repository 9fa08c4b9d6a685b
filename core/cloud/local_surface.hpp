#pragma once

#include <vector>

#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"

namespace soilvol::cloud {

/// Each point replaced by the mean of the points within `radius_m` of it, with the normal
/// (smallest PCA axis) of that neighbourhood. On a noisy surface the means lie on the surface
/// within noise / sqrt(neighbours); applied alike to two scans of one object, the smoothing
/// of edges and corners is alike too, so matching them is unbiased.
struct LocalSurface {
    Cloud points;   ///< neighbourhood means
    Cloud normals;  ///< unit normals of the neighbourhoods
    Cloud sources;  ///< the input point each mean belongs to
};

inline constexpr int kMinSurfaceNeighbors = 5;

/// Points with fewer than `min_neighbors` within the radius are dropped. On a `stop` the result
/// is partial; the caller checks the token.
LocalSurface SmoothLocalSurface(const Cloud& points, double radius_m,
                                int min_neighbors = kMinSurfaceNeighbors,
                                const StopToken& stop = {});

/// The same over weighted points: means and covariances weigh each point by its weight (one
/// per point), the neighbour count counts points. Voxel centroids weighted by their counts
/// (VoxelCentroids) give the means of the points they stand for, at any density.
LocalSurface SmoothLocalSurface(const Cloud& points, const std::vector<float>& weights,
                                double radius_m, int min_neighbors = kMinSurfaceNeighbors,
                                const StopToken& stop = {});

}  // namespace soilvol::cloud
