#include "core/volume/load_distribution.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

namespace soilvol::volume {
namespace {

/// A 2 x 1 m opening in 0.1 m cells with soil `height(x, y)`, every cell measured.
template <typename Height>
VolumeResult Result(Height height) {
    VolumeResult result;
    result.grid = MakeGrid(Polygon2d({{-1.0, -0.5}, {1.0, -0.5}, {1.0, 0.5}, {-1.0, 0.5}}), 0.1);
    const int cells = result.grid.NumCells();
    result.soil_height_m.resize(cells);
    result.state.assign(cells, CellState::kMeasured);
    for (int k = 0; k < cells; ++k) {
        const Eigen::Vector2d c = result.grid.Center(k);
        result.soil_height_m[k] = height(c.x(), c.y());
    }
    return result;
}

TEST(LoadDistribution, AnEvenLoadIsCentred) {
    const LoadDistribution d = DistributionOf(Result([](double, double) { return 0.3; }));
    EXPECT_NEAR(d.volume_m3, 0.6, 1e-9);
    EXPECT_NEAR(d.centre_m.norm(), 0.0, 1e-9);
    EXPECT_NEAR(d.positive_x_share, 0.5, 1e-9);
    EXPECT_NEAR(d.positive_y_share, 0.5, 1e-9);
    EXPECT_NEAR(d.asymmetry, 0.0, 1e-9);
}

TEST(LoadDistribution, AWedgeLeansToItsDeepSide) {
    // Height grows linearly with x from 0 at x = -1 to 0.4 at x = +1: the centroid of a
    // triangle's area lies at a third of the base from the deep side, x = 1/3.
    const LoadDistribution d =
        DistributionOf(Result([](double x, double) { return 0.2 * (x + 1.0); }));
    EXPECT_NEAR(d.volume_m3, 0.4, 1e-9);
    EXPECT_NEAR(d.centre_m.x(), 1.0 / 3.0, 0.01);
    EXPECT_NEAR(d.centre_m.y(), 0.0, 1e-9);
    EXPECT_NEAR(d.positive_x_share, 0.75, 0.01);  // the deep half holds 3/4 of a wedge
    EXPECT_NEAR(d.positive_y_share, 0.5, 1e-9);
    EXPECT_NEAR(d.asymmetry, (1.0 / 3.0) / 0.95, 0.02);  // over the cells' half-extent
}

TEST(LoadDistribution, EmptyOrBelowEmptyIsNoLoad) {
    const LoadDistribution d = DistributionOf(Result([](double, double) { return -0.01; }));
    EXPECT_EQ(d.volume_m3, 0.0);
    EXPECT_EQ(d.positive_x_share, 0.5);
    EXPECT_EQ(d.asymmetry, 0.0);
}

TEST(LoadDistribution, PackedHeightsAreLittleEndianFloatsWithNanWhereUnobserved) {
    VolumeResult result = Result([](double x, double) { return x > 0.0 ? 0.25 : 0.5; });
    result.state[1] = CellState::kInterpolated;
    result.soil_height_m[2] = std::numeric_limits<double>::quiet_NaN();
    const std::string packed = PackedHeights(result);
    ASSERT_EQ(packed.size(), static_cast<std::size_t>(result.grid.NumCells()) * 4);
    const auto at = [&](int k) {
        std::uint32_t bits = 0;
        for (int b = 0; b < 4; ++b) {
            bits |= static_cast<std::uint32_t>(static_cast<unsigned char>(packed[k * 4 + b]))
                    << (8 * b);
        }
        float value = 0.0f;
        std::memcpy(&value, &bits, sizeof value);
        return value;
    };
    EXPECT_EQ(at(0), 0.5f);  // row 0, x = -0.95
    EXPECT_TRUE(std::isnan(at(1)));
    EXPECT_TRUE(std::isnan(at(2)));
    EXPECT_EQ(at(result.grid.cols - 1), 0.25f);
}

}  // namespace
}  // namespace soilvol::volume
