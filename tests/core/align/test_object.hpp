#pragma once

#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/types.hpp"

namespace soilvol::align {

// An open box (floor and four walls, 1.2 x 0.8 x 0.5 m) with a lug on one side, sampled on a
// 1 cm grid: a shape that pins every direction of a pose.
inline Cloud Object() {
    Cloud c;
    for (double x = -0.6; x <= 0.6; x += 0.01) {
        for (double y = -0.4; y <= 0.4; y += 0.01) c.emplace_back(x, y, -0.5);
        for (double z = -0.5; z <= 0.0; z += 0.01) {
            c.emplace_back(x, -0.4, z);
            c.emplace_back(x, 0.4, z);
        }
    }
    for (double y = -0.4; y <= 0.4; y += 0.01) {
        for (double z = -0.5; z <= 0.0; z += 0.01) {
            c.emplace_back(-0.6, y, z);
            c.emplace_back(0.6, y, z);
        }
    }
    for (double x = 0.2; x <= 0.3; x += 0.01) {
        for (double z = -0.3; z <= 0.1; z += 0.01) c.emplace_back(x, 0.55, z);
    }
    return c;
}

// The model's alignment set from `points`, smoothed as ContainerModel smooths it: 3 cm voxel
// centroids weighted by their counts, means over 8 cm.
inline cloud::LocalSurface SmoothedAsModel(const Cloud& points) {
    const cloud::VoxelCentroids voxels = cloud::CentroidsOf(points, 0.03);
    return cloud::SmoothLocalSurface(voxels.points, voxels.counts, 0.08);
}

}  // namespace soilvol::align
