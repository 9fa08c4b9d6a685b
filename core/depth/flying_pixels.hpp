#pragma once

#include <cstdint>
#include <vector>

namespace soilvol::depth {

/// A ToF pixel whose footprint straddles a depth edge returns a mix of the near and the far
/// surface: a point floating between them, on neither ("flying pixel", "mixed pixel"). Along
/// some image direction (rows, columns, both diagonals) such a pixel
///   - lies apart from both neighbours, farther than `jump_ratio` of its depth and 4 noise
///     sigmas of a difference (a surface at grazing incidence steps less between pixels),
///   - between them (a lone spike nearer or farther than both is an outlier, not a mix), and
///   - on the continuation of neither side: a side is a surface when its next three pixels
///     lie on a line in inverse depth (a plane does, exactly, in the undistorted image), and
///     the pixel continues it when it lies on that line too, within the noise.
/// A surface seen at any angle continues one of its sides; a concave or convex corner both;
/// a mixed pixel, or a run of two, neither. Pixels near the border or next to pixels without
/// a return are judged on the directions where they have all their neighbours.
struct FlyingPixelConfig {
    bool enabled = true;
    /// The sensor's depth noise (1 sigma) [m] at the scene's depths.
    double noise_m = 0.005;
    /// A step between neighbours larger than this share of the depth is an edge (0.03: a
    /// surface seen under 87 deg from its normal with 1.7 mrad pixels steps less).
    double jump_ratio = 0.03;
};

/// 1 for every flying pixel of a z-depth image [m] (row-major, NaN where there is no return),
/// 0 elsewhere. Linear in pixels.
std::vector<std::uint8_t> FindFlyingPixels(const std::vector<float>& z_m, int width, int height,
                                           const FlyingPixelConfig& config);

}  // namespace soilvol::depth
