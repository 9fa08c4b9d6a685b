#include "core/cloud/local_surface.hpp"

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "core/cloud/candidate_block.hpp"
#include "core/cloud/voxel_grid.hpp"

namespace soilvol::cloud {

LocalSurface SmoothLocalSurface(const Cloud& points, double radius_m, int min_neighbors,
                                const StopToken& stop) {
    return SmoothLocalSurface(points, {}, radius_m, min_neighbors, stop);
}

LocalSurface SmoothLocalSurface(const Cloud& points, const std::vector<float>& weights,
                                double radius_m, int min_neighbors, const StopToken& stop) {
    // Voxels of the radius: every neighbour of a point lies in the 3^3 block around its voxel,
    // gathered once for all the voxel's points.
    const VoxelGrid grid(points, radius_m);
    const auto num_voxels = static_cast<long>(grid.NumVoxels());
    const auto r2 = static_cast<float>(radius_m * radius_m);
    Cloud means(points.size()), normals(points.size());
    std::vector<uint8_t> kept(points.size(), 0);
#pragma omp parallel
    {
        CandidateBlock block;
#pragma omp for schedule(dynamic, 16)
        for (long v = 0; v < num_voxels; ++v) {
            if (stop.StopRequested()) continue;
            const auto [begin, end] = grid.Range(static_cast<std::size_t>(v));
            grid.GatherBlock(grid.Coord(static_cast<std::size_t>(v)), 1, block.indices());
            block.Load(points, points[grid.Order()[begin]], weights);
            for (std::size_t o = begin; o < end; ++o) {
                const uint32_t k = grid.Order()[o];
                const Moments m = block.Within(points[k], r2);
                if (m.count < min_neighbors || m.weight <= 0.0) continue;
                const double n = m.weight;
                const Eigen::Vector3d offset = m.sum / n;
                means[k] = (points[k].cast<double>() + offset).cast<float>();
                const Eigen::Matrix3d cov = m.outer - n * offset * offset.transpose();
                // Closed form: a surface patch's smallest eigenvalue stands well apart.
                Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
                solver.computeDirect(cov);
                normals[k] = solver.eigenvectors().col(0).cast<float>();
                kept[k] = 1;
            }
        }
    }
    LocalSurface out;
    for (std::size_t k = 0; k < points.size(); ++k) {
        if (!kept[k]) continue;
        out.points.push_back(means[k]);
        out.normals.push_back(normals[k]);
        out.sources.push_back(points[k]);
    }
    return out;
}

}  // namespace soilvol::cloud
