#pragma once

#include <cstdint>
#include <vector>

namespace soilvol::depth {

/// A ToF pixel whose footprint straddles a depth edge returns a mix of the near and the far
/// surface: a point floating between them, on neither ("flying pixel", "mixed pixel"). A pixel
/// is one when
///   - along some image direction (row, column, either diagonal) its two neighbours lie apart
///     by more than `jump_ratio` of its depth and 6 noise sigmas, and per pixel by more than
///     four times what the surfaces beyond them step (a depth edge runs through it, not a
///     steep surface), and it lies between them, and
///   - along no such direction does it continue a side: the next three pixels on either side
///     lie on a line in inverse depth (a plane does, exactly, in the undistorted image) that
///     the pixel lies on too, within the side's noise.
/// A surface seen at any angle, a concave or convex corner, and a pure pixel beside an edge
/// all continue a surface; a mixed return, or a run of two, does not unless it lies so near
/// one of its surfaces that the noise hides the mix. Only directions across the edge count:
/// along a straight edge the mixed pixels form a line of their own. Pixels near the border or next
/// to pixels without a return are judged on the directions where they have their neighbours.
struct FlyingPixelConfig {
    bool enabled = true;
    /// The sensor's depth noise (1 sigma) at 1 m [m]; it grows in proportion to the depth (a
    /// ToF camera's shot noise: the returned light falls with the square of the range).
    double noise_at_1m_m = 0.002;
    /// A step between the two neighbours larger than this share of the depth is an edge (a
    /// surface steeper than this is kept by its continuation, not by this).
    double jump_ratio = 0.02;
};

/// 1 for every flying pixel of a z-depth image [m] (row-major; 0 or NaN: no return),
/// 0 elsewhere. Linear in pixels.
std::vector<std::uint8_t> FindFlyingPixels(const std::vector<float>& z_m, int width, int height,
                                           const FlyingPixelConfig& config);

}  // namespace soilvol::depth
