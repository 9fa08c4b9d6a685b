#include "core/sim/procedural_texture.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::sim {

namespace {

constexpr uint32_t kSteelSeed = 0x5eed57u;
constexpr uint32_t kSkySeed = 0x5ca1ab1eu;
constexpr uint32_t kBackdropSeed = 0xbac4d00u;

uint32_t Hash(int x, int y, int z, uint32_t seed) {
    uint32_t h = seed ^ (static_cast<uint32_t>(x) * 0x8da6b343u) ^
                 (static_cast<uint32_t>(y) * 0xd8163841u) ^
                 (static_cast<uint32_t>(z) * 0xcb1ab31fu);
    h ^= h >> 16;
    h *= 0x7feb352du;
    h ^= h >> 15;
    h *= 0x846ca68bu;
    h ^= h >> 16;
    return h;
}

// Dot product of the offset with one of Perlin's 12 edge gradients (improved noise, 2002).
double Gradient(uint32_t hash, double x, double y, double z) {
    const uint32_t h = hash & 15u;
    const double u = h < 8u ? x : y;
    const double v = h < 4u ? y : (h == 12u || h == 14u ? x : z);
    return ((h & 1u) ? -u : u) + ((h & 2u) ? -v : v);
}

double Fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

double Lerp(double a, double b, double t) { return a + t * (b - a); }

double SmoothStep(double edge0, double edge1, double x) {
    const double t = std::clamp((x - edge0) / (edge1 - edge0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}

// Sum of `octaves` noise layers, each at twice the frequency and `gain` times the amplitude.
double Fbm(const Eigen::Vector3d& p, int octaves, double gain, uint32_t seed) {
    double sum = 0.0;
    double amplitude = 1.0;
    double frequency = 1.0;
    for (int o = 0; o < octaves; ++o) {
        sum += amplitude * GradientNoise(frequency * p, seed + 101u * static_cast<uint32_t>(o));
        amplitude *= gain;
        frequency *= 2.0;
    }
    return sum;
}

}  // namespace

double GradientNoise(const Eigen::Vector3d& p, uint32_t seed) {
    const double fx = std::floor(p.x());
    const double fy = std::floor(p.y());
    const double fz = std::floor(p.z());
    const int ix = static_cast<int>(fx);
    const int iy = static_cast<int>(fy);
    const int iz = static_cast<int>(fz);
    const double x = p.x() - fx;
    const double y = p.y() - fy;
    const double z = p.z() - fz;
    const double u = Fade(x);
    const double v = Fade(y);
    const double w = Fade(z);
    double corners[2][2][2];
    for (int a = 0; a < 2; ++a) {
        for (int b = 0; b < 2; ++b) {
            for (int c = 0; c < 2; ++c) {
                corners[a][b][c] =
                    Gradient(Hash(ix + a, iy + b, iz + c, seed), x - a, y - b, z - c);
            }
        }
    }
    const double x00 = Lerp(corners[0][0][0], corners[1][0][0], u);
    const double x10 = Lerp(corners[0][1][0], corners[1][1][0], u);
    const double x01 = Lerp(corners[0][0][1], corners[1][0][1], u);
    const double x11 = Lerp(corners[0][1][1], corners[1][1][1], u);
    return Lerp(Lerp(x00, x10, v), Lerp(x01, x11, v), w);
}

double SoilAlbedo(const Eigen::Vector3d& p_m, uint32_t seed) {
    // Clods of 2-4 cm with finer crumbs down to 5 mm, plus sparse light and dark pebbles.
    const double clods = Fbm(p_m / 0.04, 4, 0.6, seed);
    const double pebbles = GradientNoise(p_m / 0.012, seed ^ 0x9e3779b9u);
    const double grain = GradientNoise(p_m / 0.004, seed ^ 0x7f4a7c15u);
    const double light = SmoothStep(0.35, 0.55, pebbles);
    const double dark = SmoothStep(0.35, 0.55, -pebbles);
    return std::clamp(0.30 + 0.22 * clods + 0.12 * light - 0.08 * dark + 0.04 * grain, 0.04, 0.9);
}

double SteelAlbedo(const Eigen::Vector3d& p_m) {
    // Blotches of 10-30 cm, medium mottling at 3 cm, scratches as zero crossings of noise
    // stretched along a fixed oblique direction, rust speckle and fine grain.
    const double blotches = Fbm(p_m / 0.25, 2, 0.5, kSteelSeed);
    const double mottling = Fbm(p_m / 0.03, 2, 0.5, kSteelSeed + 7u);
    const Eigen::Vector3d along = Eigen::Vector3d(0.8, 0.5, 0.33).normalized();
    const Eigen::Vector3d q = p_m / 0.03;
    const Eigen::Vector3d stretched = q - along * (0.95 * along.dot(q));
    const double scratch = (1.0 - SmoothStep(0.0, 0.1, std::abs(GradientNoise(stretched, 11u)))) *
                           SmoothStep(0.0, 0.3, GradientNoise(p_m / 0.2, kSteelSeed + 9u));
    const double rust = SmoothStep(0.25, 0.45, GradientNoise(p_m / 0.015, kSteelSeed + 3u));
    const double grain = GradientNoise(p_m / 0.005, kSteelSeed + 5u);
    return std::clamp(
        0.55 + 0.18 * blotches + 0.12 * mottling + 0.12 * scratch - 0.25 * rust + 0.04 * grain,
        0.05, 0.95);
}

double SkyRadiance(const Eigen::Vector3d& direction) {
    return std::clamp(0.45 + 0.35 * Fbm(direction * 12.0, 4, 0.6, kSkySeed), 0.05, 0.95);
}

double BackdropRadiance(const Eigen::Vector3d& direction) {
    return std::clamp(0.5 + 0.12 * Fbm(direction * 15.0, 3, 0.6, kBackdropSeed), 0.2, 0.8);
}

}  // namespace soilvol::sim
