#pragma once

#include <Eigen/Core>
#include <cstddef>

#include "core/common/types.hpp"

namespace soilvol::cloud {

/// How a scan samples the directions around its sensor: the angle between neighbouring returns
/// along a row, and whether the returns lie in rows much farther apart than that (a spinning
/// lidar's rings) with the angle between rows. A camera's pixel grid or a dense scanner's ray
/// grid samples alike in every direction (no rows).
struct AngularSampling {
    double along_rad = 0.0;   ///< median angle to the nearest return
    bool rows = false;        ///< the nearest returns line up, with gaps across them
    double across_rad = 0.0;  ///< median angle to the nearest return off the row (rows only)
};

/// Measured on up to `samples` evenly strided returns of `points` seen from `sensor` (same
/// frame): each one's nearest directions (up to 32) and how they spread about it. Rows when the
/// nearest 8 spread along one line (the second eigenvalue of their spread below a tenth of the
/// first) at most of the samples and the nearest return off that line is over 3 times farther
/// than along it. Fewer than 50 returns: no rows.
AngularSampling MeasureAngularSampling(const Cloud& points, const Eigen::Vector3d& sensor,
                                       std::size_t samples = 1000);

}  // namespace soilvol::cloud
