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

/// One number per pixel (a depth, a confidence or an amplitude image), row-major, as the file
/// stored it: `bits` is 8 or 16 (unsigned integers) or 32 (float).
struct ScalarImage {
    int width = 0;
    int height = 0;
    int bits = 0;
    std::vector<float> values;

    float At(int u, int v) const { return values[static_cast<size_t>(v) * width + u]; }
};

}  // namespace soilvol
