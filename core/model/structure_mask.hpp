#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/common/types.hpp"

namespace soilvol::model {

/// Columns (container frame, along the opening normal) within `radius_m` of the container's own
/// structure: walls seen inside the opening and the rim and outside around it. Range noise
/// spreads a wall's returns into the cells next to it at every height; the volume stage leaves
/// these columns to hole filling, so neither the empty surface nor the soil surface is pulled
/// up by the walls. The mask is a set of columns, not of 3D neighbourhoods: a test that depended
/// on height would keep the noise above a surface and drop the noise below it.
class StructureMask {
  public:
    /// The column grid: cols x rows cells of cell_m from lo, row-major, 1 = marked.
    struct Columns {
        double cell_m = 1.0;
        Eigen::Vector2d lo = Eigen::Vector2d::Zero();
        int cols = 0;
        int rows = 0;
        std::vector<uint8_t> marked;
    };

    StructureMask() = default;
    /// A mask from its grid (as columns() returned it); the caller checks consistency.
    explicit StructureMask(Columns columns) : columns_(std::move(columns)) {}
    /// Marks every column within `radius_m` of a point of `structure` whose height lies in
    /// [z_min, z_max], over the box [lo, hi] (xy).
    StructureMask(const Cloud& structure, double radius_m, const Eigen::Vector2d& lo,
                  const Eigen::Vector2d& hi, double z_min, double z_max);

    /// True when the column of `p` is marked.
    bool Contains(const Eigen::Vector3f& p) const;
    /// The points of `points` whose columns are not marked.
    Cloud Filter(const Cloud& points) const;
    const Columns& columns() const { return columns_; }

  private:
    Columns columns_;
};

}  // namespace soilvol::model
