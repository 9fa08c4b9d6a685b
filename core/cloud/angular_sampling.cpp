#include "core/cloud/angular_sampling.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "core/cloud/kd_tree.hpp"

namespace soilvol::cloud {
namespace {

constexpr std::size_t kMinReturns = 50;
constexpr std::size_t kLine = 8;     // nearest directions that show a row
constexpr std::size_t kAcross = 32;  // nearest directions searched for the next row
constexpr double kLineRatio = 0.1;   // second / first eigenvalue of a row's spread
constexpr double kRowGap = 3.0;      // rows: the next row this many steps away, at least

double Median(std::vector<double>& v) {
    if (v.empty()) return 0.0;
    auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
}

// What one return's neighbourhood of directions says: its nearest angle, whether its nearest
// ones line up, and the nearest angle off that line.
struct Neighbourhood {
    double nearest = 0.0;
    bool line = false;
    double across = 0.0;
};

Neighbourhood Around(const Cloud& directions, const KdTree& tree, std::size_t i) {
    Neighbourhood out;
    const Eigen::Vector3f& d = directions[i];
    const auto near = tree.Nearest(d, kAcross + 1);  // sorted, itself first
    if (near.size() < kLine + 1) return out;
    out.nearest = std::sqrt(static_cast<double>(near[1].second));
    Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
    for (std::size_t k = 1; k <= kLine; ++k) {
        const Eigen::Vector3d o = (directions[near[k].first] - d).cast<double>();
        spread += o * o.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
    solver.computeDirect(spread);
    const Eigen::Vector3d l = solver.eigenvalues();  // ascending; the first is along d, ~0
    if (!(l(2) > 0.0) || l(1) > kLineRatio * l(2)) return out;
    out.line = true;
    const Eigen::Vector3d along = solver.eigenvectors().col(2);
    out.across = 2.0;  // no return off the row among the nearest: far
    for (std::size_t k = 1; k < near.size(); ++k) {
        const Eigen::Vector3d o = (directions[near[k].first] - d).cast<double>();
        if (std::abs(o.dot(along)) < 0.5 * o.norm()) {
            out.across = o.norm();
            break;
        }
    }
    return out;
}

}  // namespace

AngularSampling MeasureAngularSampling(const Cloud& points, const Eigen::Vector3d& sensor,
                                       std::size_t samples) {
    AngularSampling out;
    if (points.size() < kMinReturns || samples == 0) return out;
    Cloud directions;
    directions.reserve(points.size());
    for (const auto& p : points) {
        const Eigen::Vector3d ray = p.cast<double>() - sensor;
        if (ray.norm() > 0.0) directions.push_back(ray.normalized().cast<float>());
    }
    if (directions.size() < kMinReturns) return out;
    const KdTree tree(directions);
    std::vector<double> nearest, across;
    std::size_t lines = 0, tested = 0;
    const std::size_t stride = std::max<std::size_t>(1, directions.size() / samples);
    for (std::size_t i = 0; i < directions.size(); i += stride) {
        const Neighbourhood n = Around(directions, tree, i);
        if (n.nearest <= 0.0) continue;
        ++tested;
        nearest.push_back(n.nearest);
        if (!n.line) continue;
        ++lines;
        across.push_back(n.across);
    }
    out.along_rad = Median(nearest);
    if (tested == 0 || 2 * lines < tested) return out;
    const double gap = Median(across);
    if (gap > kRowGap * out.along_rad) {
        out.rows = true;
        out.across_rad = gap;
    }
    return out;
}

}  // namespace soilvol::cloud
