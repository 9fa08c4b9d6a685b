#include "core/volume/heightmap_image.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace soilvol::volume {
namespace {

constexpr int kMaxSide = 4096;
constexpr double kMinSpanM = 0.05;
// Viridis at 0, 1/4, 1/2, 3/4, 1 (the dashboard uses the same stops).
constexpr std::array<std::array<double, 3>, 5> kViridis = {
    {{68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}}};

std::array<uint8_t, 3> Colour(double t) {
    const double x = std::clamp(t, 0.0, 1.0) * (kViridis.size() - 1);
    const auto i = std::min<std::size_t>(kViridis.size() - 2, static_cast<std::size_t>(x));
    const double f = x - static_cast<double>(i);
    std::array<uint8_t, 3> out{};
    for (int k = 0; k < 3; ++k) {
        out[k] = static_cast<uint8_t>(
            std::lround(kViridis[i][k] + f * (kViridis[i + 1][k] - kViridis[i][k])));
    }
    return out;
}

void Put(RgbImage& image, int u, int v, const std::array<uint8_t, 3>& rgb) {
    if (u < 0 || v < 0 || u >= image.width || v >= image.height) return;
    std::memcpy(&image.pixels[(static_cast<std::size_t>(v) * image.width + u) * 3], rgb.data(), 3);
}

}  // namespace

absl::StatusOr<std::vector<float>> UnpackHeights(std::string_view bytes, int cols, int rows) {
    if (cols <= 0 || rows <= 0 || cols > kMaxSide || rows > kMaxSide ||
        bytes.size() != static_cast<std::size_t>(cols) * rows * 4) {
        return absl::InvalidArgumentError(absl::StrCat("heightmap: ", bytes.size(), " bytes for ",
                                                       cols, " x ", rows, " float32 cells"));
    }
    std::vector<float> heights(static_cast<std::size_t>(cols) * rows);
    for (std::size_t i = 0; i < heights.size(); ++i) {
        uint32_t word = 0;
        for (int b = 3; b >= 0; --b) {
            word = (word << 8) | static_cast<uint8_t>(bytes[i * 4 + static_cast<std::size_t>(b)]);
        }
        std::memcpy(&heights[i], &word, 4);
    }
    return heights;
}

RgbImage RenderHeightmap(const std::vector<float>& heights, int cols, int rows, int cell_px,
                         std::optional<std::pair<double, double>> centre_cells) {
    cell_px = std::clamp(cell_px, 1, 64);
    RgbImage image;
    image.width = cols * cell_px;
    image.height = rows * cell_px;
    image.pixels.assign(static_cast<std::size_t>(image.width) * image.height * 3, 235);
    float low = INFINITY, high = -INFINITY;
    for (const float h : heights) {
        if (std::isnan(h)) continue;
        low = std::min(low, h);
        high = std::max(high, h);
    }
    const double span = std::max(kMinSpanM, static_cast<double>(high) - static_cast<double>(low));
    for (int row = 0; row < rows; ++row) {
        for (int col = 0; col < cols; ++col) {
            const float h = heights[static_cast<std::size_t>(row) * cols + col];
            if (std::isnan(h)) continue;
            const auto rgb = Colour(static_cast<double>(h - low) / span);
            const int v0 = (rows - 1 - row) * cell_px;  // +y up
            for (int dv = 0; dv < cell_px; ++dv) {
                for (int du = 0; du < cell_px; ++du) Put(image, col * cell_px + du, v0 + dv, rgb);
            }
        }
    }
    if (centre_cells) {
        const double cu = centre_cells->first * cell_px;
        const double cv = (rows - centre_cells->second) * cell_px;
        const double radius = std::max(4.0, 0.6 * cell_px);
        for (int v = static_cast<int>(cv - radius - 2); v <= cv + radius + 2; ++v) {
            for (int u = static_cast<int>(cu - radius - 2); u <= cu + radius + 2; ++u) {
                const double d = std::hypot(u - cu, v - cv);
                if (std::abs(d - radius) < 1.2) Put(image, u, v, {255, 255, 255});
                if ((std::abs(u - cu) < 1.0 || std::abs(v - cv) < 1.0) && d < radius + 3) {
                    Put(image, u, v, {197, 48, 48});
                }
            }
        }
    }
    return image;
}

}  // namespace soilvol::volume
