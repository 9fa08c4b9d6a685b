#include "core/depth/flying_pixels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace soilvol::depth {
namespace {

constexpr std::array<std::array<int, 2>, 4> kDirections{{{1, 0}, {0, 1}, {1, 1}, {1, -1}}};

// Tolerances, in noise sigmas of the residual they bound (independent pixels of sigma s):
//   - the pixel against the least-squares line through the side's three pixels, extrapolated
//     one step: (4 w1 + w2 - 2 w3) / 3 has sqrt(7/3) s, the residual sqrt(10/3) s;
//   - the side's own straightness w1 - 2 w2 + w3: sqrt(6) s.
constexpr double kContinueSigmas = 1.3;
constexpr double kStraightSigmas = 3.0;
constexpr double kEdgeSigmas = 6.0;
constexpr double kAbruptPerPixel = 4.0;

// Whether a depth edge runs through a pixel of depth z along a direction whose two neighbours
// have depths a and b: both returns, apart by more than `jump`, z between them; 1 or 0.
// Bitwise, not short-circuit, so that MarkEdgeCandidates' loop stays branch-free.
template <typename T>
int Across(T a, T b, T z, T jump) {
    return static_cast<int>((a > T(0)) & (b > T(0)) & (std::abs(a - b) > jump) &
                            ((z - a) * (z - b) <= T(0)));
}

// The depth image; 0, NaN or a negative depth: no return.
class Image {
  public:
    Image(const std::vector<float>& z, int width, int height)
        : z_(z.data()), width_(width), height_(height) {}

    // The depth at (u, v); 0 outside the image or without a return.
    float At(int u, int v) const {
        if (u < 0 || v < 0 || u >= width_ || v >= height_) return 0.0f;
        const float z = z_[static_cast<std::size_t>(v) * width_ + u];
        return z > 0.0f ? z : 0.0f;
    }

    double Depth(int u, int v) const { return static_cast<double>(At(u, v)); }

  private:
    const float* z_;
    int width_;
    int height_;
};

// What one side of (u, v) along a direction holds: its three depths, 0 where missing.
struct Side {
    double z1, z2, z3;
    bool complete() const { return z1 > 0.0 && z2 > 0.0 && z3 > 0.0; }
};

Side SideOf(const Image& image, int u, int v, int du, int dv) {
    return {image.Depth(u + du, v + dv), image.Depth(u + 2 * du, v + 2 * dv),
            image.Depth(u + 3 * du, v + 3 * dv)};
}

// Whether the pixel, of depth z, continues the side's surface, in inverse depth.
bool Continues(const Side& side, double z, const FlyingPixelConfig& config) {
    if (!side.complete()) return false;
    const double sigma_w = config.noise_at_1m_m / z;  // noise_at_1m_m * z / z^2, as dw = dz / z^2
    const double w1 = 1.0 / side.z1;
    const double w2 = 1.0 / side.z2;
    const double w3 = 1.0 / side.z3;
    if (std::abs(w1 - 2.0 * w2 + w3) > kStraightSigmas * std::sqrt(6.0) * sigma_w) return false;
    const double predicted = (4.0 * w1 + w2 - 2.0 * w3) / 3.0;
    return std::abs(1.0 / z - predicted) <= kContinueSigmas * std::sqrt(10.0 / 3.0) * sigma_w;
}

// Whether (u, v), of depth z, is a mixed return: some direction crosses a depth edge there and
// along no such direction does the pixel continue the surface of either side.
bool IsFlying(const Image& image, int u, int v, double z, const FlyingPixelConfig& config) {
    const double jump = std::max(config.jump_ratio, kEdgeSigmas * config.noise_at_1m_m) * z;
    bool crossed = false;
    for (const auto& d : kDirections) {
        const double a = image.Depth(u - d[0], v - d[1]);
        const double b = image.Depth(u + d[0], v + d[1]);
        if (Across(a, b, z, jump) == 0) continue;
        const Side before = SideOf(image, u, v, -d[0], -d[1]);
        const Side after = SideOf(image, u, v, d[0], d[1]);
        if (!before.complete() && !after.complete()) continue;
        // An edge, not a steep surface: per pixel, the step across the pixel exceeds
        // kAbruptPerPixel times what the surfaces beyond step (a surface at a grazing angle
        // steps about as much everywhere, and its weak return is noisier than the model).
        double slope = 0.0;
        for (const Side* side : {&before, &after}) {
            if (side->complete()) slope = std::max(slope, std::abs(side->z2 - side->z3));
        }
        if (0.5 * std::abs(a - b) <= kAbruptPerPixel * slope) continue;
        if (Continues(before, z, config) || Continues(after, z, config)) return false;
        crossed = true;
    }
    return crossed;
}

// The cheap half of IsFlying's test, for the interior pixels 1..width-2 of a row (`up`, `row`
// and `down` its rows): an edge runs through the pixel along some direction (Across, with a
// jump of jump_ratio of its depth). Branch-free, so that the compiler vectorises it: every
// pixel passes through here, few go further.
void MarkEdgeCandidates(const float* up, const float* row, const float* down, int width,
                        float jump_ratio, std::uint8_t* candidate) {
    for (int u = 1; u < width - 1; ++u) {
        const float z = row[u];
        const float jump = jump_ratio * z;
        candidate[u] = static_cast<std::uint8_t>(
            (z > 0.0f) &
            (Across(row[u - 1], row[u + 1], z, jump) | Across(up[u], down[u], z, jump) |
             Across(up[u - 1], down[u + 1], z, jump) | Across(down[u - 1], up[u + 1], z, jump)));
    }
}

}  // namespace

std::vector<std::uint8_t> FindFlyingPixels(const std::vector<float>& z_m, int width, int height,
                                           const FlyingPixelConfig& config) {
    std::vector<std::uint8_t> flying(z_m.size(), 0);
    if (!config.enabled || width < 7 || height < 7) return flying;
    const Image image(z_m, width, height);
    const float jump_ratio =
        static_cast<float>(std::max(config.jump_ratio, kEdgeSigmas * config.noise_at_1m_m));
    std::vector<std::uint8_t> candidate(static_cast<std::size_t>(width), 1);
    for (int v = 0; v < height; ++v) {
        const bool border_row = v == 0 || v == height - 1;
        if (!border_row) {
            const float* row = z_m.data() + static_cast<std::size_t>(v) * width;
            MarkEdgeCandidates(row - width, row, row + width, width, jump_ratio, candidate.data());
        }
        for (int u = 0; u < width; ++u) {
            const bool interior = !border_row && u > 0 && u < width - 1;
            if (interior && candidate[static_cast<std::size_t>(u)] == 0) continue;
            const float z = image.At(u, v);
            if (z <= 0.0f) continue;
            flying[static_cast<std::size_t>(v) * width + u] =
                IsFlying(image, u, v, static_cast<double>(z), config);
        }
    }
    return flying;
}

}  // namespace soilvol::depth
