#pragma once

#include <cstdint>
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
    StructureMask() = default;
    /// Marks every column within `radius_m` of a point of `structure` whose height lies in
    /// [z_min, z_max], over the box [lo, hi] (xy).
    StructureMask(const Cloud& structure, double radius_m, const Eigen::Vector2d& lo,
                  const Eigen::Vector2d& hi, double z_min, double z_max);

    /// True when the column of `p` is marked.
    bool Contains(const Eigen::Vector3f& p) const;
    /// The points of `points` whose columns are not marked.
    Cloud Filter(const Cloud& points) const;

  private:
    double cell_m_ = 1.0;
    Eigen::Vector2d lo_ = Eigen::Vector2d::Zero();
    int cols_ = 0;
    int rows_ = 0;
    std::vector<uint8_t> marked_;
};

}  // namespace soilvol::model
