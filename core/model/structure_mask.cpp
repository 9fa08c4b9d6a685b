#include "core/model/structure_mask.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::model {

StructureMask::StructureMask(const Cloud& structure, double radius_m, const Eigen::Vector2d& lo,
                             const Eigen::Vector2d& hi, double z_min, double z_max)
    : cell_m_(std::max(0.005, radius_m / 4.0)), lo_(lo) {
    cols_ = std::max(1, static_cast<int>(std::ceil((hi.x() - lo.x()) / cell_m_)));
    rows_ = std::max(1, static_cast<int>(std::ceil((hi.y() - lo.y()) / cell_m_)));
    marked_.assign(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_), 0);
    if (radius_m <= 0.0) return;
    // A column is marked when its centre lies within the radius of a structure point.
    const int reach = static_cast<int>(std::ceil(radius_m / cell_m_)) + 1;
    const double r2 = radius_m * radius_m;
    for (const auto& p : structure) {
        const double z = static_cast<double>(p.z());
        if (z < z_min || z > z_max) continue;
        const Eigen::Vector2d q = (p.head<2>().cast<double>() - lo_) / cell_m_;
        const int c0 = static_cast<int>(std::floor(q.x())),
                  r0 = static_cast<int>(std::floor(q.y()));
        for (int r = std::max(0, r0 - reach); r <= std::min(rows_ - 1, r0 + reach); ++r) {
            for (int c = std::max(0, c0 - reach); c <= std::min(cols_ - 1, c0 + reach); ++c) {
                const Eigen::Vector2d centre(c + 0.5, r + 0.5);
                if ((centre - q).squaredNorm() * cell_m_ * cell_m_ > r2) continue;
                marked_[static_cast<std::size_t>(r * cols_ + c)] = 1;
            }
        }
    }
}

bool StructureMask::Contains(const Eigen::Vector3f& p) const {
    if (marked_.empty()) return false;
    const double fx = std::floor((static_cast<double>(p.x()) - lo_.x()) / cell_m_);
    const double fy = std::floor((static_cast<double>(p.y()) - lo_.y()) / cell_m_);
    if (!(fx >= 0.0 && fy >= 0.0 && fx < cols_ && fy < rows_)) return false;
    return marked_[static_cast<std::size_t>(static_cast<int>(fy) * cols_ + static_cast<int>(fx))] !=
           0;
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
