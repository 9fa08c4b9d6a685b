#include "core/sim/image_sensor.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace soilvol::sim {

GreyImage ExposeImage(const std::vector<double>& grey_levels, int width, int height,
                      double noise_sigma, uint64_t seed, uint64_t stream) {
    GreyImage image;
    if (width <= 0 || height <= 0 ||
        grey_levels.size() != static_cast<size_t>(width) * static_cast<size_t>(height)) {
        return image;
    }
    image.width = width;
    image.height = height;
    image.pixels.resize(grey_levels.size());
    std::seed_seq seeds{static_cast<uint32_t>(seed), static_cast<uint32_t>(seed >> 32),
                        static_cast<uint32_t>(stream), static_cast<uint32_t>(stream >> 32)};
    std::mt19937_64 rng(seeds);
    const bool noisy = noise_sigma > 0.0;
    std::normal_distribution<double> noise(0.0, noisy ? noise_sigma : 1.0);
    for (size_t i = 0; i < grey_levels.size(); ++i) {
        double value = grey_levels[i] + (noisy ? noise(rng) : 0.0);
        if (std::isnan(value)) value = 0.0;
        image.pixels[i] = static_cast<uint8_t>(std::lround(std::clamp(value, 0.0, 255.0)));
    }
    return image;
}

}  // namespace soilvol::sim
