#pragma once

#include <vector>

#include "absl/status/statusor.h"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/volume/grid.hpp"

namespace soilvol::volume {

/// Height of a surface seen from above (container frame, z up), per grid cell, from points
/// whose noise runs along their sensor rays. Every point weighs by how much it tells about the
/// height under it (cloud::RayWeights) and by the area it stands for, so that steep walls and
/// dense patches do not dominate; the fit is symmetric in the residuals, so noise above and
/// below a surface cancel and the same surface seen twice gives the same height.
struct SurfaceConfig {
    double min_window_points = 12.0;  ///< the fit window widens until it expects this many points
    int max_window_cells = 9;         ///< widest fit window, in cells (odd)
    double tukey_sigmas = 4.685;      ///< Tukey biweight limit, in local residual sigmas
    int robust_iterations = 4;
    /// A cell is measured when returns that tell a height cover this share of its area (fine
    /// bins of a third of a cell), or, for cells finer than the returns' spacing, when its fit
    /// window holds this share of the returns the density puts there; others are holes, filled
    /// from their neighbours.
    double min_observed_fraction = 0.25;
    double max_slope = 8.0;      ///< fitted planes steeper than this (83 deg) fall back to a level
    double min_noise_m = 0.002;  ///< floor on the estimated noise sigma
    double default_noise_m = 0.02;  ///< used when too few points to estimate the noise
    int num_threads = 0;            ///< 0 = all cores
};

/// Field by field (a new field must join it: the model cache keys empty surfaces by it).
bool operator==(const SurfaceConfig& a, const SurfaceConfig& b);

/// Height of a surface at every cell anchor of a grid.
struct SurfaceMap {
    std::vector<double> height;  ///< z [m] at each cell's anchor; NaN for cells outside the opening
    std::vector<double> variance;  ///< [m^2] of each height
    std::vector<int> support;      ///< points in the cell behind each height; 0 = interpolated
    std::vector<double> observed;  ///< per cell: the share of it the returns cover
    /// Per measured cell: how far its own returns stray from its plane beyond the noise [m]
    /// (robust, ray-weighted: a curved or kinked surface the plane does not follow); 0 where
    /// the plane fits, NaN for holes.
    std::vector<double> misfit;
    double noise_sigma_m = 0.0;  ///< robust noise estimate along z
    int window_cells = 1;        ///< side of the fit window, in cells
    int measured = 0;
    int interpolated = 0;
};

/// Fits each cell's surface height by a robust weighted local plane evaluated at the cell's
/// anchor, from `points` (container frame) with per-point `weights` >= 0 (empty: all 1),
/// then fills holes as FillHoles does. FailedPrecondition when no cell is measured;
/// InvalidArgument when the weights do not match the points; DeadlineExceeded or Cancelled once
/// `stop` asks for it.
absl::StatusOr<SurfaceMap> EstimateSurface(const Grid& grid, const Cloud& points,
                                           const std::vector<float>& weights,
                                           const SurfaceConfig& config, const StopToken& stop = {});

/// Fills the NaN heights of cells with weight > 0 from the measured cells: each hole takes the
/// value at its anchor of a least-squares plane through the measured cells within 2, 4, 8, ...
/// cells of it (the first reach holding 6, or the whole grid), weighted by a Cauchy kernel
/// 1 / (1 + d^2 / s^2), s half the reach (a level when they do not spread in both directions);
/// interpolated cells get support 0 and the median measured variance, doubled.
/// On a `stop` the holes are left unfinished; the caller checks the token.
void FillHoles(const Grid& grid, SurfaceMap& map, const StopToken& stop = {});

}  // namespace soilvol::volume
