#include "core/cloud/local_surface.hpp"

#include <Eigen/Dense>

#include "core/cloud/kd_tree.hpp"

namespace soilvol::cloud {

LocalSurface SmoothLocalSurface(const Cloud& points, double radius_m, int min_neighbors) {
    const KdTree tree(points);
    LocalSurface out;
    out.points.reserve(points.size());
    out.normals.reserve(points.size());
    for (const auto& p : points) {
        const auto found = tree.Radius(p, radius_m);
        if (static_cast<int>(found.size()) < min_neighbors) continue;
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& f : found) mean += points[f.first].cast<double>();
        mean /= static_cast<double>(found.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& f : found) {
            const Eigen::Vector3d d = points[f.first].cast<double>() - mean;
            cov += d * d.transpose();
        }
        out.points.push_back(mean.cast<float>());
        out.normals.push_back(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov)
                                  .eigenvectors()
                                  .col(0)
                                  .cast<float>());
    }
    return out;
}

}  // namespace soilvol::cloud
