#include "core/depth/flying_pixels.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

namespace soilvol::depth {
namespace {

// Inverse depths along one direction: w[0] the pixel, w[1..3] one side, w[4..6] the other.
struct Line {
    std::array<double, 7> w;
};

// Whether the side w[first], w[first+1], w[first+2] is a surface the pixel continues.
bool Continues(const Line& line, int first, double tolerance) {
    const double s1 = line.w[first];
    const double s2 = line.w[first + 1];
    const double s3 = line.w[first + 2];
    const bool side_is_surface = std::abs(s1 - (2.0 * s2 - s3)) <= tolerance;
    return side_is_surface && std::abs(line.w[0] - (2.0 * s1 - s2)) <= tolerance;
}

}  // namespace

std::vector<std::uint8_t> FindFlyingPixels(const std::vector<float>& z_m, int width, int height,
                                           const FlyingPixelConfig& config) {
    std::vector<std::uint8_t> flying(z_m.size(), 0);
    if (!config.enabled || width < 7 || height < 7) return flying;
    constexpr std::array<std::array<int, 2>, 4> kDirections{{{1, 0}, {0, 1}, {1, 1}, {1, -1}}};
    const auto depth = [&](int u, int v) {
        return static_cast<double>(z_m[static_cast<std::size_t>(v) * width + u]);
    };
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            const double z = depth(u, v);
            if (!(z > 0.0)) continue;
            // A difference of two noisy depths has sqrt(2) sigmas; a continuation's residual
            // (w - 2 w1 + w2, and the side's own) sqrt(6) sigmas in inverse depth, dw = dz / z^2.
            const double jump =
                std::max(config.jump_ratio * z, 4.0 * std::sqrt(2.0) * config.noise_m);
            const double tolerance = 4.0 * std::sqrt(6.0) * config.noise_m / (z * z);
            for (const auto& d : kDirections) {
                if (u - 3 * d[0] < 0 || u + 3 * d[0] >= width || v - 3 * d[1] < 0 ||
                    v + 3 * d[1] >= height || v + 3 * d[1] < 0 || v - 3 * d[1] >= height) {
                    continue;
                }
                const double a = depth(u - d[0], v - d[1]);
                const double b = depth(u + d[0], v + d[1]);
                if (!(a > 0.0) || !(b > 0.0)) continue;
                if (std::abs(z - a) <= jump || std::abs(z - b) <= jump || (z - a) * (z - b) > 0.0) {
                    continue;
                }
                Line line{};
                line.w[0] = 1.0 / z;
                bool complete = true;
                for (int i = 1; i <= 3; ++i) {
                    const double za = depth(u - i * d[0], v - i * d[1]);
                    const double zb = depth(u + i * d[0], v + i * d[1]);
                    complete = complete && za > 0.0 && zb > 0.0;
                    line.w[static_cast<std::size_t>(i)] = 1.0 / za;
                    line.w[static_cast<std::size_t>(3 + i)] = 1.0 / zb;
                }
                if (!complete) continue;
                if (!Continues(line, 1, tolerance) && !Continues(line, 4, tolerance)) {
                    flying[static_cast<std::size_t>(v) * width + u] = 1;
                    break;
                }
            }
        }
    }
    return flying;
}

}  // namespace soilvol::depth
