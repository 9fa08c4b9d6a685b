#include "core/volume/volume_result.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace soilvol::volume {
namespace {

// dF/d(axis) at cell k from its neighbours inside the opening: central where both exist,
// one-sided at the edge, 0 for a cell alone on that axis.
double Slope(const VolumeResult& r, int k, int step, bool has_before, bool has_after) {
    const Grid& g = r.grid;
    const auto valid = [&](int j) {
        return g.weight[static_cast<std::size_t>(j)] > 0.0 &&
               std::isfinite(r.scan_surface_m[static_cast<std::size_t>(j)]);
    };
    const bool before = has_before && valid(k - step);
    const bool after = has_after && valid(k + step);
    const auto f = [&](int j) { return r.scan_surface_m[static_cast<std::size_t>(j)]; };
    if (before && after) return (f(k + step) - f(k - step)) / (2.0 * g.cell_m);
    if (after) return (f(k + step) - f(k)) / g.cell_m;
    if (before) return (f(k) - f(k - step)) / g.cell_m;
    return 0.0;
}

}  // namespace

Eigen::Matrix<double, 6, 1> VolumePoseGradient(const VolumeResult& result) {
    Eigen::Matrix<double, 6, 1> gradient = Eigen::Matrix<double, 6, 1>::Zero();
    const Grid& g = result.grid;
    if (result.scan_surface_m.size() != g.weight.size()) return gradient;
    for (int k = 0; k < g.NumCells(); ++k) {
        const auto uk = static_cast<std::size_t>(k);
        const double w = g.weight[uk];
        if (w <= 0.0 || !std::isfinite(result.scan_surface_m[uk])) continue;
        const int col = k % g.cols, row = k / g.cols;
        const Eigen::Vector3d c(-Slope(result, k, 1, col > 0, col + 1 < g.cols),
                                -Slope(result, k, g.cols, row > 0, row + 1 < g.rows), 1.0);
        const Eigen::Vector3d p(g.anchor[uk].x(), g.anchor[uk].y(), result.scan_surface_m[uk]);
        // dh = c . (p x w - t) = (c x p) . w - c . t
        gradient.head<3>() += w * c.cross(p);
        gradient.tail<3>() -= w * c;
    }
    return gradient;
}

}  // namespace soilvol::volume
