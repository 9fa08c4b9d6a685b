#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace soilvol::sim {

/// Perlin-style gradient noise at point `p` (lattice spacing 1), roughly in [-1, 1]; smooth,
/// zero at lattice points, different for each `seed`.
double GradientNoise(const Eigen::Vector3d& p, uint32_t seed);

/// Albedo in (0, 1) of soil at container-frame point `p_m` [m]: multi-octave noise with features
/// of 0.5-4 cm, mid-dark brown-grey. `seed` varies the pattern.
double SoilAlbedo(const Eigen::Vector3d& p_m, uint32_t seed);

/// Albedo in (0, 1) of container steel at `p_m` [m]: low-frequency blotches, scratches, rust
/// speckle and fine grain; lighter on average than soil and structured differently.
double SteelAlbedo(const Eigen::Vector3d& p_m);

/// Radiance in (0, 1) of the scene background at infinity seen along unit `direction`
/// (medium contrast, features of ~0.5-5 deg).
double SkyRadiance(const Eigen::Vector3d& direction);

/// Radiance in (0, 1) of the low-contrast mid-grey backdrop behind calibration boards.
double BackdropRadiance(const Eigen::Vector3d& direction);

}  // namespace soilvol::sim
