#pragma once

#include <cmath>

#include "core/sim/scene.hpp"

namespace soilvol::sim {

/// Midpoint integral of -InnerSurfaceZ over the opening [m^3], on cells of at most `cell_m`.
inline double IntegrateInnerSurface(const ContainerGeometry& c, double cell_m) {
    const int cols = static_cast<int>(std::ceil(c.opening_length_m / cell_m));
    const int rows = static_cast<int>(std::ceil(c.opening_width_m / cell_m));
    const double dx = c.opening_length_m / cols;
    const double dy = c.opening_width_m / rows;
    double sum = 0.0;
    for (int j = 0; j < rows; ++j) {
        for (int i = 0; i < cols; ++i) {
            sum -= c.InnerSurfaceZ(-0.5 * c.opening_length_m + (i + 0.5) * dx,
                                   -0.5 * c.opening_width_m + (j + 0.5) * dy);
        }
    }
    return sum * dx * dy;
}

}  // namespace soilvol::sim
