#include "core/volume/heightmap_image.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace soilvol::volume {
namespace {

std::string Pack(const std::vector<float>& heights) {
    std::string bytes(heights.size() * 4, '\0');
    for (std::size_t i = 0; i < heights.size(); ++i) {
        uint32_t word = 0;
        std::memcpy(&word, &heights[i], 4);
        for (int b = 0; b < 4; ++b) bytes[i * 4 + b] = static_cast<char>((word >> (8 * b)) & 0xff);
    }
    return bytes;
}

std::array<uint8_t, 3> Pixel(const RgbImage& image, int u, int v) {
    const std::size_t at = (static_cast<std::size_t>(v) * image.width + u) * 3;
    return {image.pixels[at], image.pixels[at + 1], image.pixels[at + 2]};
}

TEST(HeightmapImage, UnpacksLittleEndianAndRefusesWrongSizes) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const std::vector<float> heights = {0.0f, 0.25f, -0.5f, nan, 1e-3f, 3.0f};
    const absl::StatusOr<std::vector<float>> got = UnpackHeights(Pack(heights), 3, 2);
    ASSERT_TRUE(got.ok()) << got.status();
    for (std::size_t i = 0; i < heights.size(); ++i) {
        if (std::isnan(heights[i])) {
            EXPECT_TRUE(std::isnan((*got)[i]));
        } else {
            EXPECT_EQ((*got)[i], heights[i]);
        }
    }
    EXPECT_FALSE(UnpackHeights(Pack(heights), 2, 2).ok());
    EXPECT_FALSE(UnpackHeights("", 0, 0).ok());
    EXPECT_FALSE(UnpackHeights(std::string(7, 'x'), 1, 2).ok());
    EXPECT_FALSE(UnpackHeights("", 5000, 1).ok());
}

TEST(HeightmapImage, ColoursRunLowToHighWithYUpAndGreyWhereUnobserved) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // 2 x 2 cells: row 0 (min y) low and unobserved, row 1 (max y) high.
    const std::vector<float> heights = {0.1f, nan, 0.5f, 0.5f};
    const RgbImage image = RenderHeightmap(heights, 2, 2, 10, std::nullopt);
    ASSERT_EQ(image.width, 20);
    ASSERT_EQ(image.height, 20);
    // Row 0 is drawn at the bottom: its low cell is viridis' dark end.
    EXPECT_EQ(Pixel(image, 5, 15), (std::array<uint8_t, 3>{68, 1, 84}));
    EXPECT_EQ(Pixel(image, 15, 15), (std::array<uint8_t, 3>{235, 235, 235}));
    EXPECT_EQ(Pixel(image, 5, 5), (std::array<uint8_t, 3>{253, 231, 37}));
    // A flat load stays nearly one colour: the range is at least 5 cm, so 1 mm of noise moves
    // a colour by 2 % of the scale, not across it.
    const RgbImage flat = RenderHeightmap({0.2f, 0.201f}, 2, 1, 4, std::nullopt);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(Pixel(flat, 1, 1)[k], Pixel(flat, 5, 1)[k], 10);
}

TEST(HeightmapImage, MarksTheLoadCentre) {
    const std::vector<float> heights(20 * 10, 0.3f);
    const RgbImage image = RenderHeightmap(heights, 20, 10, 8, std::make_pair(15.0, 5.0));
    // The cross at (15, 5) cells: x = 120 px, y from the top = (10 - 5) * 8 = 40 px.
    EXPECT_EQ(Pixel(image, 120, 40), (std::array<uint8_t, 3>{197, 48, 48}));
    EXPECT_NE(Pixel(image, 40, 40), (std::array<uint8_t, 3>{197, 48, 48}));
}

}  // namespace
}  // namespace soilvol::volume
