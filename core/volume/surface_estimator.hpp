#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/volume/grid.hpp"

namespace soilvol::volume {

/// Robust per-cell height of a surface seen from above (container frame, z up).
struct SurfaceConfig {
    double min_window_points = 12.0;  ///< the fit window widens until it expects this many points
    int max_window_cells = 9;         ///< widest fit window, in cells (odd)
    double inlier_sigmas = 2.5;       ///< inlier band around the fit, in noise sigmas
    int ransac_iterations = 48;
    double support_ratio = 0.5;          ///< hypotheses with this share of the best support compete
    double min_support_fraction = 0.25;  ///< of the points the window should hold; fewer: a hole
    double max_slope =
        6.0;  ///< steeper fits (over 80 deg) are walls, not a surface seen from above
    double min_noise_m = 0.002;     ///< floor on the estimated noise sigma
    double default_noise_m = 0.02;  ///< used when too few points to estimate the noise
    int num_threads = 0;            ///< 0 = all cores
};

/// Height of a surface at every cell anchor of a grid.
struct SurfaceMap {
    std::vector<double> height;  ///< z [m] at each cell's anchor; NaN for cells outside the opening
    std::vector<double> variance;  ///< [m^2] of each height
    std::vector<int> support;      ///< inlier points behind each height; 0 = interpolated
    double noise_sigma_m = 0.0;    ///< robust noise estimate along z
    int window_cells = 1;          ///< side of the fit window, in cells
    int measured = 0;
    int interpolated = 0;
};

/// Fits each cell's surface height robustly (RANSAC then trimmed least squares of a height-form
/// plane evaluated at the cell's anchor) from `points` in the container frame, then fills holes by
/// harmonic interpolation. FailedPrecondition when no cell has enough points.
absl::StatusOr<SurfaceMap> EstimateSurface(const Grid& grid, const Cloud& points,
                                           const SurfaceConfig& config);

/// Fills the NaN heights of cells with weight > 0 by harmonic (Laplace) interpolation from the
/// measured cells; interpolated cells get support 0 and the median measured variance, doubled.
void FillHoles(const Grid& grid, SurfaceMap& map);

}  // namespace soilvol::volume
