#include "core/model/structure_mask.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::model {

StructureMask::StructureMask(const Cloud& structure, double radius_m, const Eigen::Vector2d& lo,
                             const Eigen::Vector2d& hi, double z_min, double z_max) {
    Columns& g = columns_;
    g.cell_m = std::max(0.005, radius_m / 4.0);
    g.lo = lo;
    g.cols = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / g.cell_m)));
    g.rows = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / g.cell_m)));
    g.marked.assign(static_cast<std::size_t>(g.cols) * static_cast<std::size_t>(g.rows), 0);
    if (radius_m <= 0.0) return;
    // A column is marked when its centre lies within the radius of a structure point.
    const int reach = static_cast<int>(std::ceil(radius_m / g.cell_m)) + 1;
    const double r2 = radius_m * radius_m;
    for (const auto& p : structure) {
        const double z = static_cast<double>(p.z());
        if (z < z_min || z > z_max) continue;
        const Eigen::Vector2d q = (p.head<2>().cast<double>() - g.lo) / g.cell_m;
        const int c0 = static_cast<int>(std::floor(q.x())),
                  r0 = static_cast<int>(std::floor(q.y()));
        for (int r = std::max(0, r0 - reach); r <= std::min(g.rows - 1, r0 + reach); ++r) {
            for (int c = std::max(0, c0 - reach); c <= std::min(g.cols - 1, c0 + reach); ++c) {
                const Eigen::Vector2d centre(c + 0.5, r + 0.5);
                if ((centre - q).squaredNorm() * g.cell_m * g.cell_m > r2) continue;
                g.marked[static_cast<std::size_t>(r * g.cols + c)] = 1;
            }
        }
    }
}

bool StructureMask::Contains(const Eigen::Vector3f& p) const {
    const Columns& g = columns_;
    if (g.marked.empty()) return false;
    const double fx = std::floor((static_cast<double>(p.x()) - g.lo.x()) / g.cell_m);
    const double fy = std::floor((static_cast<double>(p.y()) - g.lo.y()) / g.cell_m);
    if (!(fx >= 0.0 && fy >= 0.0 && fx < g.cols && fy < g.rows)) return false;
    return g.marked[static_cast<std::size_t>(static_cast<int>(fy) * g.cols +
                                             static_cast<int>(fx))] != 0;
}

Cloud StructureMask::Filter(const Cloud& points) const {
    Cloud kept;
    kept.reserve(points.size());
    for (const auto& p : points) {
        if (!Contains(p)) kept.push_back(p);
    }
    return kept;
}

}  // namespace soilvol::model
