#pragma once

#include <Eigen/Core>
#include <string>

#include "core/volume/volume_result.hpp"

namespace soilvol::volume {

/// Where the soil lies in the opening, in the container frame (origin at the opening's
/// centroid, x along corner 0 -> 1): what a truck scanner reports as front/rear and left/right
/// distribution. Cells weigh by their soil volume (height above the empty surface, clipped at
/// 0, times the cell's area inside the opening).
struct LoadDistribution {
    double volume_m3 = 0.0;                              ///< the positive soil the shares split
    Eigen::Vector2d centre_m = Eigen::Vector2d::Zero();  ///< volume-weighted centroid (x, y)
    double positive_x_share = 0.5;  ///< of that volume on the +x side of the centroid's y axis
    double positive_y_share = 0.5;  ///< on the +y side
    /// |centre| over the opening's half-extent along the centre's direction, 0 (centred) to 1
    /// (all at the rim).
    double asymmetry = 0.0;
};

/// The distribution of `result`'s soil; an empty load (no positive soil) is centred with shares
/// of 0.5. A cell straddling an axis splits by where its centre lies.
LoadDistribution DistributionOf(const VolumeResult& result);

/// The soil heights of `result`'s grid as little-endian float32, row-major from the grid's min
/// corner (x fastest), NaN where the scan observed nothing (outside the opening, and cells
/// filled from neighbours).
std::string PackedHeights(const VolumeResult& result);

}  // namespace soilvol::volume
