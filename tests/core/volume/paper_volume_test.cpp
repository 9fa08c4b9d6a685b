#include "core/volume/paper_volume.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace soilvol::volume {
namespace {

const Polygon2d kSquare({{0.0, 0.0}, {0.2, 0.0}, {0.2, 0.2}, {0.0, 0.2}});

// Points of the plane z = z0 on a regular lattice over [x0, x1] x [y0, y1].
void AddLattice(Cloud& cloud, double x0, double x1, double y0, double y1, double z0) {
    for (double x = x0; x <= x1 + 1e-9; x += 0.01) {
        for (double y = y0; y <= y1 + 1e-9; y += 0.01) cloud.emplace_back(x, y, z0);
    }
}

TEST(PaperVolumeTest, HandComputedFlatFillWithAHole) {
    // 2 x 2 cells of 0.1 m. Floor at -0.5 everywhere; soil at -0.3 in three cells, the fourth
    // (x > 0.1, y > 0.1) has no points and takes its neighbours' mean plane (z = -0.3).
    Cloud floor, soil;
    AddLattice(floor, 0.005, 0.195, 0.005, 0.195, -0.5);
    AddLattice(soil, 0.005, 0.095, 0.005, 0.195, -0.3);
    AddLattice(soil, 0.105, 0.195, 0.005, 0.095, -0.3);
    const auto result = PaperVolume(floor, soil, kSquare, PaperConfig{});
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->cells.total, 4);
    EXPECT_EQ(result->cells.interpolated, 1);
    // Measured cells: lattice medians coincide, height 0.2 m. The hole's median point is its
    // centre (0.15, 0.15) while the floor's is the upper median (0.155, 0.155).
    const double hole_height = std::sqrt(0.2 * 0.2 + 2 * 0.005 * 0.005);
    EXPECT_NEAR(result->volume_m3, 0.01 * (3 * 0.2 + hole_height), 1e-9);
}

TEST(PaperVolumeTest, HeightIsEuclideanDistanceBetweenMedianPoints) {
    // Soil points only in the left third of each cell: the median points are offset
    // horizontally by 0.03 m from the floor's, so each height is hypot(0.03, 0.2).
    Cloud floor, soil;
    AddLattice(floor, 0.01, 0.09, 0.01, 0.09, -0.5);
    AddLattice(soil, 0.01, 0.03, 0.01, 0.09, -0.3);
    const Polygon2d cell({{0.0, 0.0}, {0.1, 0.0}, {0.1, 0.1}, {0.0, 0.1}});
    const auto result = PaperVolume(floor, soil, cell, PaperConfig{});
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_NEAR(result->soil_height_m[0], std::hypot(0.03, 0.2), 1e-5);
    EXPECT_NEAR(result->volume_m3, 0.01 * std::hypot(0.03, 0.2), 1e-7);
}

TEST(PaperVolumeTest, WholeCellsOverTheBoundingBoxAsInTable2) {
    // Table 2: a 15 cm grid over 2.05 x 0.54 m has 56 cells of full area.
    const Polygon2d bucket({{0.0, 0.0}, {2.05, 0.0}, {2.05, 0.54}, {0.0, 0.54}});
    Cloud floor, soil;
    AddLattice(floor, 0.0, 2.05, 0.0, 0.54, -0.6);
    AddLattice(soil, 0.0, 2.05, 0.0, 0.54, -0.6);
    PaperConfig config;
    config.cell_m = 0.15;
    const auto result = PaperVolume(floor, soil, bucket, config);
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->cells.total, 56);
    EXPECT_NEAR(result->volume_m3, 0.0, 1e-9);
}

TEST(PaperVolumeTest, NoScanPlaneIsAnError) {
    Cloud floor;
    AddLattice(floor, 0.005, 0.195, 0.005, 0.195, -0.5);
    const auto result = PaperVolume(floor, Cloud{}, kSquare, PaperConfig{});
    ASSERT_FALSE(result.ok());
    EXPECT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace soilvol::volume
