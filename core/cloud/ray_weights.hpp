#pragma once

#include <vector>

#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"

namespace soilvol::cloud {

/// How much a point tells about the height of the surface under it when its noise runs along
/// the sensor ray. A return displaced by e along the unit ray r on a surface with unit normal n
/// moves off the surface by e (r.n) and, read as a height, by e (r.n) / n_z: the inverse
/// variance of a height reading is v = n_z^2 / (r.n)^2, the point's weight (capped at 4): 1 on
/// a floor seen from straight above, 2 from 45 deg, 0 on a vertical wall.
struct RayWeightConfig {
    double voxel_m = 0.03;      ///< the normals come from a voxel-averaged copy of the points
    double radius_m = 0.05;     ///< neighbourhood of each normal, at least
    double noise_sigmas = 2.5;  ///< ... and at least this many noise sigmas
};

/// Weight of every point of `points` (container frame, z up) seen from `sensor_origin` (same
/// frame) with range noise `noise_sigma_m`. Points without a normal (isolated) get 0. On a
/// `stop` the weights are left unfinished; the caller checks the token.
std::vector<float> RayWeights(const Cloud& points, const Eigen::Vector3d& sensor_origin,
                              double noise_sigma_m, const RayWeightConfig& config,
                              const StopToken& stop = {});

}  // namespace soilvol::cloud
