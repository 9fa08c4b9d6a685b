#include <gtest/gtest.h>

#include <cmath>

#include "core/common/angles.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"
#include "tests/core/sim/inner_surface_integral.hpp"

namespace soilvol::sim {
namespace {

// Angle [deg] from the opening plane of the profile's first (front) and last (back) segments.
std::pair<double, double> WallAngles(const ContainerGeometry& c) {
    const auto& p = c.inner_profile_yz;
    const auto angle = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
        return std::atan2(std::abs(b.y() - a.y()), std::abs(b.x() - a.x())) * 180.0 / kPi;
    };
    return {angle(p[0], p[1]), angle(p[p.size() - 2], p[p.size() - 1])};
}

TEST(ContainerFamilyTest, EveryFamilyHasItsExactCapacityAndNoOverhang) {
    for (const ContainerFamily family : AllFamilies()) {
        for (uint64_t seed = 1; seed <= 6; ++seed) {
            const ContainerShape shape = RandomShape(family, seed);
            const ContainerGeometry c = MakeContainer(shape);
            EXPECT_NEAR(c.opening_length_m, shape.length_m, 1e-12);
            EXPECT_NEAR(c.opening_width_m, shape.width_m, 1e-12);
            EXPECT_NEAR(c.depth_m, shape.depth_m, 1e-12);
            EXPECT_NEAR(c.struck_capacity_m3, IntegrateInnerSurface(c, 0.002),
                        2e-3 * c.struck_capacity_m3)
                << FamilyName(family) << " seed " << seed;
            for (std::size_t i = 1; i < c.inner_profile_yz.size(); ++i) {
                EXPECT_GE(c.inner_profile_yz[i].x(), c.inner_profile_yz[i - 1].x());
            }
            EXPECT_FALSE(c.triangles.empty());
        }
    }
}

TEST(ContainerFamilyTest, DimensionsAndWallsStayInTheirFamilyRanges) {
    for (uint64_t seed = 1; seed <= 20; ++seed) {
        const ContainerShape body = RandomShape(ContainerFamily::kFlaredBody, seed);
        EXPECT_GE(body.length_m, 3.0);
        EXPECT_LE(body.length_m, 6.0);
        const ContainerShape bucket = RandomShape(ContainerFamily::kBox, seed);
        EXPECT_GE(std::max(bucket.length_m, bucket.width_m), 0.5);
        EXPECT_LE(std::max(bucket.length_m, bucket.width_m), 2.5);
        const auto [front, back] =
            WallAngles(MakeContainer(RandomShape(ContainerFamily::kSlopedAsymmetric, seed)));
        EXPECT_GE(front, 55.0 - 1e-9);
        EXPECT_LE(front, 90.0 + 1e-9);
        EXPECT_GE(back, 55.0 - 1e-9);
        const auto [sf, sb] =
            WallAngles(MakeContainer(RandomShape(ContainerFamily::kSlopedSymmetric, seed)));
        EXPECT_NEAR(sf, sb, 1e-9);
    }
}

TEST(ContainerFamilyTest, ExcavatorBackCurvesFromVerticalAtTheRimToTheFloor) {
    const ContainerGeometry c = MakeContainer(RandomShape(ContainerFamily::kExcavator, 3));
    const auto& p = c.inner_profile_yz;
    const Eigen::Vector2d rim = p.back(), below = p[p.size() - 2];
    EXPECT_GT(std::abs(rim.y() - below.y()), 3.0 * std::abs(rim.x() - below.x()));  // > 71 deg
    const auto [front, back] = WallAngles(c);
    EXPECT_LT(front, 76.0);
    EXPECT_GT(back, 75.0);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(0.0, p[2].x() - 0.01), -c.depth_m);  // flat floor
}

TEST(ContainerFamilyTest, HighSideRisesAboveTheOpeningOnItsBackEdge) {
    const ContainerShape shape = RandomShape(ContainerFamily::kHighSideBin, 2);
    ASSERT_GT(shape.high_side_m, 0.0);
    const ContainerGeometry c = MakeContainer(shape);
    const SceneRaycaster scene(c, SoilSurface(c, SoilSpec{}, 1));
    // A ray along -y above the opening meets the high side at the back edge.
    const auto hit = scene.Cast({0.0, 2.0, 0.5 * shape.high_side_m}, {0.0, -1.0, 0.0}, 5.0);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(*hit, 2.0 - 0.5 * shape.width_m - shape.wall_m, 1e-6);
}

TEST(ContainerFamilyTest, ShapesAndViewpointsAreSeeded) {
    for (const ContainerFamily family : AllFamilies()) {
        const ContainerShape a = RandomShape(family, 4), b = RandomShape(family, 4);
        EXPECT_EQ(a.length_m, b.length_m);
        EXPECT_EQ(a.front_wall_deg, b.front_wall_deg);
        EXPECT_NE(a.length_m, RandomShape(family, 5).length_m);
        const SensorSpec s = ViewpointFor(a, 4);
        EXPECT_GE(s.elevation_deg, 50.0);
        EXPECT_LE(s.elevation_deg, 65.0);
        EXPECT_EQ(s.azimuth_deg, ViewpointFor(a, 4).azimuth_deg);
    }
}

TEST(ContainerFamilyTest, SceneOfAShapeSeesItsInside) {
    SceneSpec spec;
    spec.shape = RandomShape(ContainerFamily::kSlopedSymmetric, 1);
    spec.sensor = ViewpointFor(*spec.shape, 1);
    spec.soil.fill_height_m = 0.5 * spec.shape->depth_m;
    const Scene scene = SimulateScene(spec);
    EXPECT_GT(scene.points.size(), 1000u);
    EXPECT_NEAR(scene.struck_capacity_m3, MakeContainer(*spec.shape).struck_capacity_m3, 1e-12);
    EXPECT_GT(scene.true_volume_m3, 0.2 * scene.struck_capacity_m3);
    EXPECT_LT(scene.true_volume_m3, 0.6 * scene.struck_capacity_m3);
}

}  // namespace
}  // namespace soilvol::sim
