#include "core/cloud/outlier_filter.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/cloud/kd_tree.hpp"
#include "core/cloud/voxel_grid.hpp"

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
    const double n = static_cast<double>(points.size());
    const Eigen::Vector3d extent = (hi - lo).cast<double>().cwiseMax(1e-3);
    double h = std::cbrt(extent.prod() / n) * 2.0;
    for (int pass = 0; pass < 2; ++pass) {
        const VoxelGrid grid(points, h);
        const double per_voxel = n / static_cast<double>(grid.NumVoxels());
        const double surface_density = per_voxel / (h * h);
        h = 1.2 * std::sqrt(static_cast<double>(k) / (kPi * surface_density));
    }
    return std::max(h, 1e-4);
}

// Mean k-NN distance of `i` from the candidates; negative when the grid block cannot prove
// that the k nearest are among them.
float MeanFromCandidates(const Cloud& points, uint32_t i, const std::vector<uint32_t>& candidates,
                         int k, double h, std::vector<float>& scratch) {
    scratch.clear();
    const Eigen::Vector3f& p = points[i];
    for (const uint32_t j : candidates) {
        if (j != i) scratch.push_back((points[j] - p).squaredNorm());
    }
    const auto kk = static_cast<std::size_t>(k);
    if (scratch.size() < kk) return -1.0f;
    std::nth_element(scratch.begin(), scratch.begin() + static_cast<long>(kk - 1), scratch.end());
    if (static_cast<double>(scratch[kk - 1]) > h * h) return -1.0f;
    double sum = 0.0;
    for (std::size_t j = 0; j < kk; ++j) sum += std::sqrt(static_cast<double>(scratch[j]));
    return static_cast<float>(sum / static_cast<double>(k));
}

void GatherBlock(const VoxelGrid& grid, const Eigen::Vector3i& c, std::vector<uint32_t>& out) {
    out.clear();
    for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
                const int64_t v = grid.Find(c + Eigen::Vector3i(dx, dy, dz));
                if (v < 0) continue;
                const auto [begin, end] = grid.Range(static_cast<std::size_t>(v));
                out.insert(out.end(), grid.Order().begin() + static_cast<long>(begin),
                           grid.Order().begin() + static_cast<long>(end));
            }
        }
    }
}

}  // namespace

std::vector<float> MeanNeighborDistances(const Cloud& points, int k, int num_threads) {
    std::vector<float> mean(points.size(), -1.0f);
    if (k <= 0 || points.size() <= static_cast<std::size_t>(k)) return mean;
    const double h = NeighborVoxelSize(points, k);
    const VoxelGrid grid(points, h);
    const int threads = num_threads > 0 ? num_threads : omp_get_max_threads();
    const auto num_voxels = static_cast<long>(grid.NumVoxels());
#pragma omp parallel num_threads(threads)
    {
        std::vector<uint32_t> candidates;
        std::vector<float> scratch;
#pragma omp for schedule(dynamic, 32)
        for (long v = 0; v < num_voxels; ++v) {
            GatherBlock(grid, grid.Coord(static_cast<std::size_t>(v)), candidates);
            const auto [begin, end] = grid.Range(static_cast<std::size_t>(v));
            for (std::size_t o = begin; o < end; ++o) {
                const uint32_t i = grid.Order()[o];
                mean[i] = MeanFromCandidates(points, i, candidates, k, h, scratch);
            }
        }
    }
    // Sparse points: exact k-NN from a k-d tree.
    std::vector<uint32_t> sparse;
    for (uint32_t i = 0; i < points.size(); ++i) {
        if (mean[i] < 0.0f) sparse.push_back(i);
    }
    if (sparse.empty()) return mean;
    const KdTree tree(points);
    const auto kk = static_cast<std::size_t>(k) + 1;
#pragma omp parallel for schedule(dynamic, 16) num_threads(threads)
    for (long s = 0; s < static_cast<long>(sparse.size()); ++s) {
        const uint32_t i = sparse[static_cast<std::size_t>(s)];
        double sum = 0.0;
        std::size_t used = 0;
        for (const auto& [j, dist2] : tree.Knn(points[i], kk)) {
            if (j == i || used == kk - 1) continue;
            sum += std::sqrt(static_cast<double>(dist2));
            ++used;
        }
        mean[i] = static_cast<float>(sum / static_cast<double>(std::max<std::size_t>(used, 1)));
    }
    return mean;
}

OutlierFilterResult RemoveStatisticalOutliers(const Cloud& points,
                                              const OutlierFilterConfig& config) {
    OutlierFilterResult result;
    if (config.mean_k <= 0 || points.size() <= static_cast<std::size_t>(config.mean_k)) {
        result.kept = points;
        return result;
    }
    const std::vector<float> mean =
        MeanNeighborDistances(points, config.mean_k, config.num_threads);
    const double n = static_cast<double>(points.size());
    const double sum = std::accumulate(mean.begin(), mean.end(), 0.0);
    const double mu = sum / n;
    double sq = 0.0;
    for (const float d : mean) sq += (static_cast<double>(d) - mu) * (static_cast<double>(d) - mu);
    const double sigma = std::sqrt(sq / std::max(n - 1.0, 1.0));
    result.mean_distance_m = mu;
    result.threshold_m = mu + config.stddev_mul * sigma;
    result.kept.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (static_cast<double>(mean[i]) <= result.threshold_m) result.kept.push_back(points[i]);
    }
    result.removed = points.size() - result.kept.size();
    return result;
}

}  // namespace soilvol::cloud
