#include "core/sim/scene_raycaster.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::sim {
namespace {

SoilSpec FillTo(double height_m, double perturbation_m) {
    SoilSpec soil;
    soil.fill_height_m = height_m;
    soil.perturbation_m = perturbation_m;
    return soil;
}

TEST(SceneRaycasterTest, CastHitFindsTheSameDistanceAsCast) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    const SceneRaycaster raycaster(bucket, SoilSurface(bucket, FillTo(0.3, 0.04), 3));
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    const Eigen::Vector3d origin(0.8, -1.5, 1.6);
    int soil = 0, container = 0;
    for (int k = 0; k < 2000; ++k) {
        const Eigen::Vector3d target(1.2 * unit(rng), 0.5 * unit(rng), -0.3 + 0.3 * unit(rng));
        const Eigen::Vector3d direction = (target - origin).normalized();
        const std::optional<double> distance = raycaster.Cast(origin, direction, 10.0);
        const std::optional<RayHit> hit = raycaster.CastHit(origin, direction, 10.0);
        ASSERT_EQ(distance.has_value(), hit.has_value());
        if (!hit) continue;
        ASSERT_EQ(hit->distance, *distance);
        ASSERT_NEAR(hit->normal.norm(), 1.0, 1e-12);
        ASSERT_LT(hit->normal.dot(direction), 0.0);  // faces the ray origin
        (hit->material == SurfaceMaterial::kSoil ? soil : container)++;
    }
    EXPECT_GT(soil, 200);
    EXPECT_GT(container, 200);
}

TEST(SceneRaycasterTest, NormalsOfFlatSoilFloorAndWallsAreAxes) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    const Eigen::Vector3d origin(0.0, -1.0, 2.0);
    // Flat soil 0.3 m deep: straight down onto z = -0.3.
    const SceneRaycaster filled(bucket, SoilSurface(bucket, FillTo(0.3, 0.0), 1));
    const Eigen::Vector3d down = (Eigen::Vector3d(0.1, 0.05, -0.3) - origin).normalized();
    const std::optional<RayHit> soil = filled.CastHit(origin, down, 10.0);
    ASSERT_TRUE(soil.has_value());
    EXPECT_EQ(soil->material, SurfaceMaterial::kSoil);
    EXPECT_NEAR((soil->normal - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-9);
    EXPECT_NEAR((origin + soil->distance * down).z(), -0.3, 1e-4);
    // Empty bucket: the floor faces up, the far (+y) inner wall faces -y, towards the viewer.
    const SceneRaycaster empty(bucket, SoilSurface(bucket, FillTo(0.0, 0.0), 1));
    const Eigen::Vector3d to_floor = (Eigen::Vector3d(0.0, 0.0, -0.6) - origin).normalized();
    const std::optional<RayHit> floor = empty.CastHit(origin, to_floor, 10.0);
    ASSERT_TRUE(floor.has_value());
    EXPECT_EQ(floor->material, SurfaceMaterial::kContainer);
    EXPECT_NEAR((floor->normal - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
    const Eigen::Vector3d to_wall = (Eigen::Vector3d(0.0, 0.27, -0.2) - origin).normalized();
    const std::optional<RayHit> wall = empty.CastHit(origin, to_wall, 10.0);
    ASSERT_TRUE(wall.has_value());
    EXPECT_NEAR((wall->normal + Eigen::Vector3d::UnitY()).norm(), 0.0, 1e-12);
}

TEST(SceneRaycasterTest, FlatSoilIsHitAtItsLevelFromEveryDirection) {
    // A flat surface gives a soil box of zero height; no ray may slip through it to the floor.
    for (const double fill : {0.1, 0.25, 0.3}) {
        const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
        const SceneRaycaster raycaster(bucket, SoilSurface(bucket, FillTo(fill, 0.0), 1));
        std::mt19937_64 rng(3);
        std::uniform_real_distribution<double> unit(-1.0, 1.0);
        const Eigen::Vector3d origin(0.5, -0.8, 2.5);
        for (int k = 0; k < 500; ++k) {
            const Eigen::Vector3d target(0.9 * unit(rng), 0.2 * unit(rng), fill - 0.6);
            const Eigen::Vector3d direction = (target - origin).normalized();
            const std::optional<RayHit> hit = raycaster.CastHit(origin, direction, 10.0);
            ASSERT_TRUE(hit.has_value());
            if (hit->material == SurfaceMaterial::kContainer) continue;  // a wall in front
            ASSERT_NEAR((origin + hit->distance * direction - target).norm(), 0.0, 1e-4) << fill;
        }
    }
}

TEST(SceneRaycasterTest, RayIntoTheSkyMisses) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    const SceneRaycaster raycaster(bucket, SoilSurface(bucket, FillTo(0.3, 0.02), 1));
    EXPECT_FALSE(raycaster.CastHit({0.0, -1.0, 2.0}, Eigen::Vector3d::UnitZ(), 10.0).has_value());
}

}  // namespace
}  // namespace soilvol::sim
