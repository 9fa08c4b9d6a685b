#include "core/cloud/local_surface.hpp"

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "core/cloud/kd_tree.hpp"

namespace soilvol::cloud {

LocalSurface SmoothLocalSurface(const Cloud& points, double radius_m, int min_neighbors) {
    const KdTree tree(points);
    const auto n = static_cast<long>(points.size());
    Cloud means(points.size()), normals(points.size());
    std::vector<uint8_t> kept(points.size(), 0);
#pragma omp parallel for schedule(dynamic, 64)
    for (long i = 0; i < n; ++i) {
        const auto found = tree.Radius(points[static_cast<std::size_t>(i)], radius_m);
        if (static_cast<int>(found.size()) < min_neighbors) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& f : found) mean += points[f.first].cast<double>();
        mean /= static_cast<double>(found.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& f : found) {
            const Eigen::Vector3d d = points[f.first].cast<double>() - mean;
            cov += d * d.transpose();
        }
        const auto k = static_cast<std::size_t>(i);
        means[k] = mean.cast<float>();
        normals[k] =
            Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvectors().col(0).cast<float>();
        kept[k] = 1;
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
