#include "core/depth/flying_pixels.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

namespace soilvol::depth {
namespace {

constexpr int kStepWidth = 64;
constexpr int kStepHeight = 48;
constexpr double kFocalPx = 500.0;

// z of the plane n . X = d seen through pixel (u, v) of a pinhole camera (cx, cy at the centre).
double PlaneZ(const Eigen::Vector3d& normal, double offset, int u, int v) {
    const Eigen::Vector3d ray((u - kStepWidth / 2.0) / kFocalPx, (v - kStepHeight / 2.0) / kFocalPx,
                              1.0);
    return offset / normal.dot(ray);
}

std::size_t Count(const std::vector<std::uint8_t>& flags) {
    std::size_t n = 0;
    for (std::uint8_t f : flags) n += f;
    return n;
}

// A near plane left of column 32 and a far one right of it, with one column of returns that
// mixed both (the share of the far surface in its footprint: 0.5).
std::vector<float> StepWithMixedColumn(double near_z, double far_z, int mixed_columns) {
    std::vector<float> z(static_cast<std::size_t>(kStepWidth) * kStepHeight);
    for (int v = 0; v < kStepHeight; ++v) {
        for (int u = 0; u < kStepWidth; ++u) {
            double value = u < 32 ? near_z : far_z;
            if (u >= 32 && u < 32 + mixed_columns) {
                const double share = (u - 31.0) / (mixed_columns + 1.0);
                value = near_z + share * (far_z - near_z);
            }
            z[static_cast<std::size_t>(v) * kStepWidth + u] = static_cast<float>(value);
        }
    }
    return z;
}

TEST(FlyingPixelsTest, MixedReturnsAtAStepAreFlaggedAndNothingElse) {
    for (int mixed = 1; mixed <= 2; ++mixed) {
        const auto z = StepWithMixedColumn(2.0, 3.0, mixed);
        const auto flags = FindFlyingPixels(z, kStepWidth, kStepHeight, {});
        // Rows too near the top and bottom border have no vertical/diagonal view, but the
        // horizontal one decides a vertical edge: every row is judged.
        EXPECT_EQ(Count(flags), static_cast<std::size_t>(mixed * kStepHeight)) << mixed;
        for (int v = 0; v < kStepHeight; ++v) {
            for (int u = 0; u < kStepWidth; ++u) {
                const bool is_mixed = u >= 32 && u < 32 + mixed;
                EXPECT_EQ(flags[static_cast<std::size_t>(v) * kStepWidth + u] != 0, is_mixed)
                    << u << "," << v;
            }
        }
    }
}

TEST(FlyingPixelsTest, AStepWithoutMixingKeepsEveryReturn) {
    const auto z = StepWithMixedColumn(2.0, 3.0, 0);
    EXPECT_EQ(Count(FindFlyingPixels(z, kStepWidth, kStepHeight, {})), 0u);
}

TEST(FlyingPixelsTest, SurfacesAtGrazingAnglesAndCornersAreKept) {
    // A plane seen 85 deg from its normal at the centre (its depth steps 1.3-8.5% per pixel,
    // from 0.7 to 4.3 m), a concave corner (a wall meeting a floor: the nearer of the two
    // planes is seen) and a ridge (the farther).
    const double grazing = 85.0 * M_PI / 180.0;
    const Eigen::Vector3d tilted(std::sin(grazing), 0.0, std::cos(grazing));
    const Eigen::Vector3d wall = Eigen::Vector3d(1.0, 0.0, 0.3).normalized();
    const Eigen::Vector3d floor = Eigen::Vector3d(-1.0, 0.0, 0.6).normalized();
    std::vector<float> plane(static_cast<std::size_t>(kStepWidth) * kStepHeight);
    std::vector<float> corner(plane.size());
    std::vector<float> ridge(plane.size());
    for (int v = 0; v < kStepHeight; ++v) {
        for (int u = 0; u < kStepWidth; ++u) {
            const std::size_t i = static_cast<std::size_t>(v) * kStepWidth + u;
            plane[i] = static_cast<float>(PlaneZ(tilted, 0.1, u, v));
            const double a = PlaneZ(wall, 1.0, u, v);
            const double b = PlaneZ(floor, 1.5, u, v);
            corner[i] = static_cast<float>(std::min(a, b));
            ridge[i] = static_cast<float>(std::max(a, b));
        }
    }
    for (float z : plane) ASSERT_GT(z, 0.0f);
    EXPECT_EQ(Count(FindFlyingPixels(plane, kStepWidth, kStepHeight, {})), 0u);
    EXPECT_EQ(Count(FindFlyingPixels(corner, kStepWidth, kStepHeight, {})), 0u);
    EXPECT_EQ(Count(FindFlyingPixels(ridge, kStepWidth, kStepHeight, {})), 0u);
}

TEST(FlyingPixelsTest, NoiseOnASurfaceIsNotAnEdge) {
    // 3 m away, 5 mm noise (the config's): at most 0.1% of the returns flagged.
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 0.005);
    std::vector<float> z(static_cast<std::size_t>(kStepWidth) * kStepHeight);
    for (float& value : z) value = static_cast<float>(3.0 + noise(rng));
    EXPECT_LE(Count(FindFlyingPixels(z, kStepWidth, kStepHeight, {})), z.size() / 1000);
}

TEST(FlyingPixelsTest, PixelsWithoutReturnsAndSmallImagesAreNoCase) {
    auto z = StepWithMixedColumn(2.0, 3.0, 1);
    for (int v = 0; v < kStepHeight; ++v)
        z[static_cast<std::size_t>(v) * kStepWidth + 33] = std::nanf("");
    const auto flags = FindFlyingPixels(z, kStepWidth, kStepHeight, {});
    EXPECT_EQ(flags.size(), z.size());
    // Column 32 lost its far neighbour in every direction that crosses the edge.
    EXPECT_EQ(Count(flags), 0u);
    const std::vector<float> tiny(6 * 6, 1.0f);
    EXPECT_EQ(Count(FindFlyingPixels(tiny, 6, 6, {})), 0u);
    FlyingPixelConfig off;
    off.enabled = false;
    EXPECT_EQ(
        Count(FindFlyingPixels(StepWithMixedColumn(2.0, 3.0, 1), kStepWidth, kStepHeight, off)),
        0u);
}

}  // namespace
}  // namespace soilvol::depth
