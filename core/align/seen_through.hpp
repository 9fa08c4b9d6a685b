#pragma once

#include <cstddef>

#include "core/common/types.hpp"

namespace soilvol::align {

/// Free-space evidence against a pose. The sensor sits at the scan frame's origin; a model
/// point the scan's rays passed through (every return in its direction within the angular
/// tolerance lies farther than the point by more than the margin) floats in space the sensor
/// saw empty. At the right pose the model's outside lies where rays end or behind what they hit
/// (occlusion is no evidence either way); at a wrong one, a partial match leaves much of it in
/// free space.
struct SeenThroughConfig {
    /// Directions within this many scan spacings count as the same ray (the spacing is the
    /// median angle between neighbouring returns).
    double spacings = 2.0;
    double margin_sigmas = 4.0;  ///< behind the point by more than this many noise sigmas
    double min_margin_m = 0.05;  ///< and at least this
    /// Returns kept for the test (evenly strided): the spacing and the tolerance grow with the
    /// stride, the test stays the same.
    std::size_t max_returns = 8192;
};

struct SeenThrough {
    std::size_t tested = 0;   ///< model points with returns in their direction
    std::size_t through = 0;  ///< of those, seen through
    double Share() const { return tested > 0 ? static_cast<double>(through) / tested : 0.0; }
};

/// `model_in_scan`: model points in the scan frame; `scan`: the returns (scan frame);
/// `noise_sigma_m`: the sensor's range noise.
SeenThrough SeenThroughShare(const Cloud& model_in_scan, const Cloud& scan, double noise_sigma_m,
                             const SeenThroughConfig& config = {});

}  // namespace soilvol::align
