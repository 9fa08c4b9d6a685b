#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/common/polygon.hpp"

namespace soilvol::volume {

/// A regular grid of square cells over the opening's bounding box, in the container frame.
/// Cells are row-major: index = row * cols + col, x grows with col, y with row.
struct Grid {
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();  ///< min corner [m]
    double cell_m = 0.0;
    int cols = 0;
    int rows = 0;
    std::vector<double> weight;           ///< area [m^2] of each cell inside the opening
    std::vector<Eigen::Vector2d> anchor;  ///< centroid of each cell's part inside the opening

    int NumCells() const { return cols * rows; }
    Eigen::Vector2d Center(int index) const {
        return origin + cell_m * Eigen::Vector2d(index % cols + 0.5, index / cols + 0.5);
    }
    /// Cell holding (x, y), or -1 outside the grid.
    int CellOf(double x, double y) const;
};

/// Columns (x) and rows (y) of a grid of `cell_m` (> 0) over the opening's bounding box from its
/// min corner, at least 1 each; an extent within 1e-9 cells of a multiple of the cell adds no
/// column. Doubles, since tiny cells count past an int.
Eigen::Vector2d GridShape(const Polygon2d& opening, double cell_m);

/// Cells [count] of that grid (the product of GridShape).
double GridCells(const Polygon2d& opening, double cell_m);

/// Covers `opening` with the GridShape cells of `cell_m` (> 0), starting at its min corner. Each
/// cell's weight is its exact area inside the opening, so the weights sum to the opening area at
/// any size, and its anchor is the centroid of that area: a planar surface evaluated at the anchor
/// times the weight is its exact integral over the cell.
Grid MakeGrid(const Polygon2d& opening, double cell_m);

/// Point indices per cell (CSR): points of cell i are index[start[i] .. start[i + 1]).
struct CellBins {
    std::vector<int> start;
    std::vector<int> index;
};

/// Bins xy of `points` (container frame, only those with keep[i] != 0 when keep is non-empty).
template <class PointT>
CellBins BinPoints(const Grid& grid, const std::vector<PointT>& points) {
    CellBins bins;
    std::vector<int> cell(points.size(), -1);
    bins.start.assign(static_cast<std::size_t>(grid.NumCells()) + 1, 0);
    for (std::size_t i = 0; i < points.size(); ++i) {
        cell[i] =
            grid.CellOf(static_cast<double>(points[i].x()), static_cast<double>(points[i].y()));
        if (cell[i] >= 0) ++bins.start[static_cast<std::size_t>(cell[i]) + 1];
    }
    for (std::size_t c = 1; c < bins.start.size(); ++c) bins.start[c] += bins.start[c - 1];
    bins.index.resize(static_cast<std::size_t>(bins.start.back()));
    std::vector<int> fill(bins.start.begin(), bins.start.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i) {
        if (cell[i] >= 0)
            bins.index[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell[i])]++)] =
                static_cast<int>(i);
    }
    return bins;
}

}  // namespace soilvol::volume
