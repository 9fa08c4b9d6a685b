#include "core/volume/grid.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace soilvol::volume {

int Grid::CellOf(double x, double y) const {
    const double fx = std::floor((x - origin.x()) / cell_m);
    const double fy = std::floor((y - origin.y()) / cell_m);
    if (!(fx >= 0.0 && fy >= 0.0 && fx < cols && fy < rows)) return -1;
    return static_cast<int>(fy) * cols + static_cast<int>(fx);
}

Eigen::Vector2d GridShape(const Polygon2d& opening, double cell_m) {
    const Eigen::Vector2d extent = opening.Max() - opening.Min();
    // A tiny tolerance keeps an exact multiple of the cell size from adding an empty column.
    return {std::max(1.0, std::ceil(extent.x() / cell_m - 1e-9)),
            std::max(1.0, std::ceil(extent.y() / cell_m - 1e-9))};
}

double GridCells(const Polygon2d& opening, double cell_m) {
    return GridShape(opening, cell_m).prod();
}

Grid MakeGrid(const Polygon2d& opening, double cell_m) {
    Grid grid;
    grid.cell_m = cell_m;
    grid.origin = opening.Min();
    const Eigen::Vector2d shape = GridShape(opening, cell_m);
    grid.cols = static_cast<int>(shape.x());
    grid.rows = static_cast<int>(shape.y());
    grid.weight.resize(static_cast<std::size_t>(grid.NumCells()));
    grid.anchor.resize(static_cast<std::size_t>(grid.NumCells()));
    for (int i = 0; i < grid.NumCells(); ++i) {
        const Eigen::Vector2d lo =
            grid.origin + cell_m * Eigen::Vector2d(i % grid.cols, i / grid.cols);
        const auto k = static_cast<std::size_t>(i);
        std::tie(grid.weight[k], grid.anchor[k]) =
            opening.Clip(lo, lo + Eigen::Vector2d(cell_m, cell_m));
    }
    return grid;
}

}  // namespace soilvol::volume
