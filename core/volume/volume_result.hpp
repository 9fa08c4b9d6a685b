#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/volume/grid.hpp"

namespace soilvol::volume {

enum class Method {
    kHeightmap,  ///< soilvol's estimator (default)
    kPaper,      ///< paper Sec. 3.4, kept as a baseline
};

/// State of one grid cell in a result.
enum class CellState : uint8_t { kOutside = 0, kMeasured = 1, kInterpolated = 2 };

struct CellCounts {
    int total = 0;         ///< cells with any area inside the opening
    int measured = 0;      ///< cells whose soil surface was fitted from points
    int interpolated = 0;  ///< holes filled from neighbouring cells
    int with_soil = 0;     ///< cells whose soil height exceeds twice its own uncertainty
    /// measured cells whose scan surface lies below the empty one by 3 sigmas (of the cell and
    /// of the scan's noise, whichever is larger)
    int below_empty = 0;
    int both_measured = 0;  ///< cells measured in the scan and in the empty model
};

/// Soil volume over a grid, with the per-cell heightmap behind it.
struct VolumeResult {
    double volume_m3 = 0.0;                  ///< max(0, raw_volume_m3)
    double raw_volume_m3 = 0.0;              ///< signed sum of cell volumes, noise not clipped
    double uncertainty_m3 = 0.0;             ///< 1-sigma from the per-cell statistics
    double unobserved_uncertainty_m3 = 0.0;  ///< its part from empty surface no scan saw
    Grid grid;
    std::vector<double> soil_height_m;  ///< per cell, soil surface minus empty surface; NaN outside
    std::vector<double> scan_surface_m;  ///< per cell, the scan's surface height; NaN outside
    std::vector<CellState> state;        ///< per cell
    CellCounts cells;
    double scan_observed_share = 0.0;   ///< of the opening's area, measured in the scan
    double empty_observed_share = 0.0;  ///< of the opening's area, measured in the empty model
    double scan_noise_sigma_m = 0.0;    ///< robust noise along z in the scan's cells
    double model_noise_sigma_m = 0.0;   ///< same for the empty model
    int window_cells = 1;               ///< side of the fit window, in cells
};

/// d volume / d pose error [m^3 per rad, per m]: how the volume moves when the scan's points,
/// in the container frame, are off by a small rigid motion (rotation w, translation t; a point
/// p truly lies at p - w x p - t). Each cell's height changes by c . (p x w - t) with
/// c = (-dF/dx, -dF/dy, 1) the scan surface's upward normal, unnormalised: a tilt lifts one
/// side and lowers the other, a lateral shift moves walls and heap flanks through their cells.
Eigen::Matrix<double, 6, 1> VolumePoseGradient(const VolumeResult& result);

}  // namespace soilvol::volume
