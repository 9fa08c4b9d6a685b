#pragma once

#include <cstdint>
#include <vector>

namespace soilvol {

/// An 8-bit grey image, row-major, `pixels.size() == width * height`.
struct GreyImage {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> pixels;

    uint8_t At(int u, int v) const { return pixels[static_cast<size_t>(v) * width + u]; }
};

/// An 8-bit RGB image, row-major, 3 bytes (r, g, b) per pixel.
struct RgbImage {
    int width = 0;
    int height = 0;
    std::vector<uint8_t> pixels;
};

}  // namespace soilvol
