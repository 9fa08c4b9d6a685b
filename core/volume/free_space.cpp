#include "core/volume/free_space.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

namespace soilvol::volume {

std::vector<double> FreeSpaceCeiling(const Grid& grid, const std::vector<WeightedCloud>& scans) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    // The third lowest ray of each cell: a stray return behind a surface does not lower it.
    std::vector<std::array<double, 3>> lowest(static_cast<std::size_t>(grid.NumCells()),
                                              {kInf, kInf, kInf});
    const Eigen::Vector2d lo = grid.origin;
    const Eigen::Vector2d hi = grid.origin + grid.cell_m * Eigen::Vector2d(grid.cols, grid.rows);
    const double step = grid.cell_m;
    const double inv_cell = 1.0 / grid.cell_m;
    // Rays are far denser than cells: a few per fine bin bound a cell as well as all of them.
    const double area = grid.cell_m * grid.cell_m * grid.cols * grid.rows;
    const auto wanted =
        static_cast<std::size_t>(std::max(2000.0, 4.0 * area / (grid.cell_m * grid.cell_m)));
    for (const WeightedCloud& scan : scans) {
        const std::size_t stride = std::max<std::size_t>(1, scan.points.size() / wanted);
        for (std::size_t i = 0; i < scan.points.size(); i += stride) {
            const Eigen::Vector3f& p = scan.points[i];
            const Eigen::Vector3d q = p.cast<double>();
            const Eigen::Vector3d d = q - scan.sensor;
            const double horizontal = d.head<2>().norm();
            if (horizontal < step) continue;
            // Clip the ray's xy to the grid box, then walk it back from one cell before its return.
            double t_enter = 0.0;
            for (int axis = 0; axis < 2; ++axis) {
                if (std::abs(d[axis]) < 1e-12) continue;
                const double a = (lo[axis] - scan.sensor[axis]) / d[axis];
                const double b = (hi[axis] - scan.sensor[axis]) / d[axis];
                t_enter = std::max(t_enter, std::min(a, b));
            }
            const double t_stop = 1.0 - grid.cell_m / horizontal;
            const double dt = step / horizontal;
            // The walk in grid units (cells), one cell per step.
            const Eigen::Vector3d start = scan.sensor + t_stop * d;
            const double gx = (start.x() - lo.x()) * inv_cell, gy = (start.y() - lo.y()) * inv_cell;
            const double sx = d.x() * dt * inv_cell, sy = d.y() * dt * inv_cell, sz = d.z() * dt;
            const int steps = static_cast<int>(std::ceil((t_stop - t_enter) / dt));
            for (int k = 0; k < steps; ++k) {
                const double fx = gx - k * sx, fy = gy - k * sy;
                if (!(fx >= 0.0 && fy >= 0.0 && fx < grid.cols && fy < grid.rows)) continue;
                const double z = start.z() - k * sz;
                auto& l = lowest[static_cast<std::size_t>(static_cast<int>(fy) * grid.cols +
                                                          static_cast<int>(fx))];
                if (z >= l[2]) continue;
                l[2] = z;
                if (l[2] < l[1]) std::swap(l[1], l[2]);
                if (l[1] < l[0]) std::swap(l[0], l[1]);
            }
        }
    }
    std::vector<double> ceiling(lowest.size());
    for (std::size_t k = 0; k < lowest.size(); ++k) ceiling[k] = lowest[k][2];
    return ceiling;
}

}  // namespace soilvol::volume
