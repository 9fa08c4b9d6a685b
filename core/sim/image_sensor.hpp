#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/image.hpp"

namespace soilvol::sim {

/// An 8-bit image of `grey_levels` (row-major, width * height values on a 0-255 scale) with
/// Gaussian noise of `noise_sigma` grey levels (<= 0: none) drawn from the random stream
/// (`seed`, `stream`), then clamped and rounded. A size mismatch gives an empty image.
GreyImage ExposeImage(const std::vector<double>& grey_levels, int width, int height,
                      double noise_sigma, uint64_t seed, uint64_t stream);

}  // namespace soilvol::sim
