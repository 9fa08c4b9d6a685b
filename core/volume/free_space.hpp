#pragma once

#include <vector>

#include "core/common/types.hpp"
#include "core/volume/grid.hpp"

namespace soilvol::volume {

/// Highest surface each cell can hold [m]: every ray from the sensor to a return crossed free
/// space, so the surface under the cell's anchor lies below the rays that passed over it (the
/// third lowest is taken, so that a stray return does not count).
/// +inf where no ray passed (outside the opening too). About four rays per cell are followed,
/// in steps of a cell, up to one cell short of their return (which lies on the surface).
std::vector<double> FreeSpaceCeiling(const Grid& grid, const std::vector<WeightedCloud>& scans);

}  // namespace soilvol::volume
