#include "core/cloud/outlier_filter.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/cloud/candidate_block.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/statistics.hpp"

namespace soilvol::cloud {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Voxel size such that the k nearest neighbours of a point on a surface fall, with margin,
// inside the 3x3x3 voxel block around it: pi r^2 rho = k on a surface of density rho.
double NeighborVoxelSize(const Cloud& points, int k) {
    Eigen::Vector3f lo = points.front(), hi = points.front();
    for (const auto& p : points) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    // Density from every 8th point (a surface's density scales with the share kept).
    constexpr std::size_t kStride = 8;
    Cloud sample;
    for (std::size_t i = 0; i < points.size(); i += kStride) sample.push_back(points[i]);
    const double n = static_cast<double>(points.size());
    const double m = static_cast<double>(sample.size());
    const Eigen::Vector3d extent = (hi - lo).cast<double>().cwiseMax(1e-3);
    double h = std::cbrt(extent.prod() / n) * 2.0;
    for (int pass = 0; pass < 2; ++pass) {
        const VoxelGrid grid(sample, h * std::sqrt(static_cast<double>(kStride)));
        // Sample voxels of h sqrt(8) hold as many sample points as full voxels of h hold points.
        const double per_voxel = m / static_cast<double>(grid.NumVoxels());
        const double surface_density = per_voxel / (h * h);
        h = 1.2 * std::sqrt(static_cast<double>(k) / (kPi * surface_density));
    }
    return std::max(h, 1e-4);
}

// Mean k-NN distance of `i` from the candidates, all points within `h` of it; negative when
// fewer than k lie within h (then the k nearest are not proven to be among them), or, with
// `bound`, the lower bound that counts each missing neighbour at distance h.
float MeanFromCandidates(const Cloud& points, uint32_t i, const CandidateBlock& block, int k,
                         double h, bool bound, std::vector<float>& d2, std::vector<float>& near) {
    // Only candidates within h can be proven to be among the k nearest.
    block.SquaredDistances(points[i], d2);
    near.clear();
    const auto h2 = static_cast<float>(h * h);
    const std::vector<uint32_t>& index = block.index();
    for (std::size_t j = 0; j < d2.size(); ++j) {
        if (d2[j] <= h2 && index[j] != i) near.push_back(d2[j]);
    }
    const auto kk = static_cast<std::size_t>(k);
    if (near.size() < kk) {
        if (!bound) return -1.0f;
        double sum = static_cast<double>(kk - near.size()) * h;
        for (const float d : near) sum += std::sqrt(static_cast<double>(d));
        return static_cast<float>(sum / static_cast<double>(k));
    }
    std::nth_element(near.begin(), near.begin() + static_cast<long>(kk - 1), near.end());
    double sum = 0.0;
    for (std::size_t j = 0; j < kk; ++j) sum += std::sqrt(static_cast<double>(near[j]));
    return static_cast<float>(sum / static_cast<double>(k));
}

}  // namespace

std::vector<float> MeanNeighborDistances(const Cloud& points, int k, int num_threads,
                                         const StopToken& stop) {
    std::vector<float> mean(points.size(), -1.0f);
    if (k <= 0 || points.size() <= static_cast<std::size_t>(k)) return mean;
    const double h = NeighborVoxelSize(points, k);
    const VoxelGrid grid(points, h);
    const int threads = num_threads > 0 ? num_threads : omp_get_max_threads();
    const auto num_voxels = static_cast<long>(grid.NumVoxels());
    // Pass 1: the 3^3 block holds every point within h; pass 2, for the points with fewer than
    // k there: the 5^3 block holds every point within 2h, else a lower bound is kept.
    for (const int reach : {1, 2}) {
#pragma omp parallel num_threads(threads)
        {
            CandidateBlock block;
            std::vector<float> d2, near;
#pragma omp for schedule(dynamic, 32)
            for (long v = 0; v < num_voxels; ++v) {
                if (stop.StopRequested()) continue;
                const auto [begin, end] = grid.Range(static_cast<std::size_t>(v));
                bool needed = false;
                for (std::size_t o = begin; o < end && !needed; ++o)
                    needed = mean[grid.Order()[o]] < 0.0f;
                if (!needed) continue;
                grid.GatherBlock(grid.Coord(static_cast<std::size_t>(v)), reach, block.indices());
                block.Load(points, points[grid.Order()[begin]]);
                for (std::size_t o = begin; o < end; ++o) {
                    const uint32_t i = grid.Order()[o];
                    if (mean[i] >= 0.0f) continue;
                    mean[i] =
                        MeanFromCandidates(points, i, block, k, reach * h, reach == 2, d2, near);
                }
            }
        }
    }
    return mean;
}

OutlierFilterResult RemoveStatisticalOutliers(const Cloud& points,
                                              const OutlierFilterConfig& config,
                                              const StopToken& stop) {
    OutlierFilterResult result;
    if (config.mean_k <= 0 || points.size() <= static_cast<std::size_t>(config.mean_k)) {
        result.kept = points;
        return result;
    }
    // Voxel centroids stand for their points (every point is its own voxel when voxel_m <= 0).
    VoxelCentroids voxels;
    if (config.voxel_m > 0.0) {
        voxels = CentroidsOf(points, config.voxel_m);
    } else {
        voxels.points = points;
        voxels.voxel_of.resize(points.size());
        std::iota(voxels.voxel_of.begin(), voxels.voxel_of.end(), uint32_t{0});
    }
    const Cloud& centroids = voxels.points;
    const std::vector<uint32_t>& voxel_of = voxels.voxel_of;
    if (centroids.size() <= static_cast<std::size_t>(config.mean_k)) {
        result.kept = points;
        return result;
    }
    if (stop.StopRequested()) return result;
    const std::vector<float> mean =
        MeanNeighborDistances(centroids, config.mean_k, config.num_threads, stop);
    if (stop.StopRequested()) return result;
    // PCL's statistics are over the points: each centroid weighs the returns it stands for, so
    // a dense surface's few centroids are not outweighed by isolated returns (one each).
    const MeanSd stats = WeightedMeanSd(mean, [&](std::size_t v) {
        return voxels.counts.empty() ? 1.0 : static_cast<double>(voxels.counts[v]);
    });
    result.mean_distance_m = stats.mean;
    result.threshold_m = stats.mean + config.stddev_mul * stats.sd;
    result.kept.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (static_cast<double>(mean[voxel_of[i]]) <= result.threshold_m)
            result.kept.push_back(points[i]);
    }
    result.removed = points.size() - result.kept.size();
    return result;
}

}  // namespace soilvol::cloud
