#pragma once

#include <cstddef>
#include <ostream>
#include <string>

#include "core/common/polygon.hpp"
#include "core/common/types.hpp"
#include "core/sim/scene.hpp"
#include "core/volume/grid.hpp"

namespace soilvol::bench {

/// The simulator's inner surface over cell k of a grid of the model frame: its mean over the
/// cell's part inside the opening, as a grid holds a surface [m, model frame].
double TrueEmptyCell(const volume::Grid& grid, const Polygon2d& opening, std::size_t k,
                     const sim::ContainerGeometry& geometry, const Pose& T_sim_model);

/// The error budget: every estimate of the families table (each family, sensor and
/// registration kind) split by substituting the simulator's truth for one stage at a time:
///   pose  = estimate at the found pose - estimate at the true pose
///   empty = the latter - the same with the true empty surface
///   soil  = the latter - the true soil surface integrated over the same grid
///   grid  = the latter - the true volume (the grid's own quadrature)
/// The four terms sum to the error. In % of the true struck capacity.
std::string BudgetTable(int seeds, std::ostream& kv);

/// The found pose against the true one on the paper bucket (4 cm noise, 0.5 deg, moves up to
/// 3 deg / 5 cm), at every fill of Table 1: the opening centre's height error along its normal
/// and the tilt, median and 95th percentile.
std::string PoseTable(int seeds, std::ostream& kv);

}  // namespace soilvol::bench
