#pragma once

#include <vector>

#include "core/common/polygon.hpp"
#include "core/common/types.hpp"
#include "core/volume/heightmap_volume.hpp"

namespace soilvol::model {

/// A thin-shell prior for the walls one view saw only from outside. A view from one side sees
/// the outside of the near wall, not its inside (the wall itself hides it); when that wall leans
/// over the opening its outside even lies under the opening. A wall is a shell of one
/// thickness: its inner face is its outer face moved inwards by the wall's thickness, which the
/// view measures where the outer face meets the rim (the inner face passes through the opening's
/// edge there, by the opening's definition).
struct ThinShellConfig {
    double top_band_m = 0.06;   ///< the outer face below this depth (a lip or flange above) ...
    double fit_depth_m = 0.30;  ///< ... down to this depth
    double reach_m = 0.20;      ///< outer-face returns within this of an edge (outside)
    double min_thickness_m = 0.003;
    double max_thickness_m = 0.12;
    double min_thickness_sigma_m = 0.002;  ///< a measured thickness is never surer than this
    std::size_t min_points = 20;           ///< an edge with fewer outer-face returns gets no prior
    double bin_m = 0.025;  ///< the outer face: medians of bins this size (along, depth)
    std::size_t min_bin_points = 5;
    /// Inner-face points nearer the edge than this are left out: a vertical wall's inner face
    /// is the opening's edge itself, which the empty surface's bounds already hold.
    double min_lean_m = 0.015;
};

/// One wall's inner face as the prior gives it: the opening edge (vertex `edge` to the next) it
/// hangs from, its thickness at the rim [m, horizontal], and its profile: at each depth z
/// [m, < 0, descending] how far inside the edge the inner face lies [m].
struct WallPrior {
    int edge = 0;
    double thickness_m = 0.0;
    double thickness_sigma_m = 0.0;        ///< its 1-sigma, from the profile's scatter
    std::vector<Eigen::Vector2d> profile;  ///< (z, inward offset)
    std::size_t support = 0;               ///< outer-face returns it rests on
};

/// The priors of one view: the walls whose outside faces the view's sensor (the sensor lies
/// beyond their edge), that lean over the opening (their outside was seen under it), and whose
/// thickness the view measured; the view saw the inside of the others.
std::vector<WallPrior> InnerFaceFromOutside(const Cloud& outside, const Eigen::Vector3d& sensor,
                                            const Polygon2d& opening,
                                            const ThinShellConfig& config = {});

/// Height [m] of the inner face of a prior wall that leans over (x, y), the highest of them;
/// NaN where none does.
double PriorHeight(const std::vector<WallPrior>& walls, const Polygon2d& opening,
                   const Eigen::Vector2d& xy);

/// Raises the cells of `empty` (a surface over `grid`) that no empty scan saw to the prior walls'
/// inner faces where they stand above it, each cell as the mean of sub-samples (a wall's foot
/// inside a cell counts by its share): where a wall stands there is no capacity. Cells it
/// changes count as observed.
void ApplyWallPriors(const std::vector<WallPrior>& walls, const Polygon2d& opening,
                     const volume::Grid& grid, volume::EmptySurface& empty);

/// One wall per edge: the prior of `add` replaces that of `walls` on its edge when it rests on
/// more returns.
void MergeWalls(const std::vector<WallPrior>& add, std::vector<WallPrior>& walls);

}  // namespace soilvol::model
