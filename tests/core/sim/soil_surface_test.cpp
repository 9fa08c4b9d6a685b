#include "core/sim/soil_surface.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/common/timer.hpp"

namespace soilvol::sim {
namespace {

SoilSpec Fill(double height_m, double perturbation_m) {
    SoilSpec soil;
    soil.fill_height_m = height_m;
    soil.perturbation_m = perturbation_m;
    return soil;
}

// Exact area [m^2] between the level z = level and the profile where the profile is below it.
double AreaBelowLevel(const std::vector<Eigen::Vector2d>& profile, double level) {
    double area = 0.0;
    for (size_t i = 0; i + 1 < profile.size(); ++i) {
        Eigen::Vector2d a = profile[i];
        Eigen::Vector2d b = profile[i + 1];
        if (a.y() >= level && b.y() >= level) continue;
        // Clip the segment to the part below the level.
        const auto cut = [&](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
            return p + (q - p) * (level - p.y()) / (q.y() - p.y());
        };
        if (a.y() > level) a = cut(a, b);
        if (b.y() > level) b = cut(b, a);
        area += 0.5 * ((level - a.y()) + (level - b.y())) * (b.x() - a.x());
    }
    return area;
}

TEST(SoilSurfaceTest, FlatFillOfTheBoxIsItsSlab) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    for (const double h : {0.1, 0.3, 0.6}) {
        EXPECT_NEAR(TrueSoilVolume(bucket, Fill(h, 0.0), 1), 2.05 * 0.54 * h, 1e-9) << h;
    }
}

TEST(SoilSurfaceTest, FlatFillOfTheExcavatorBucketFollowsItsProfile) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kExcavatorBucket);
    for (const double h : {0.1, 0.4, 0.75}) {
        const double exact = 1.2 * AreaBelowLevel(bucket.inner_profile_yz, h - 0.75);
        EXPECT_NEAR(TrueSoilVolume(bucket, Fill(h, 0.0), 1), exact, 5e-4 * exact) << h;
    }
    EXPECT_NEAR(1.2 * AreaBelowLevel(bucket.inner_profile_yz, 0.0), bucket.struck_capacity_m3,
                1e-12);
}

TEST(SoilSurfaceTest, PerturbedFillStaysNearTheFlatFillAndConverges) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    const double area = 2.05 * 0.54;
    for (const uint64_t seed : {1u, 2u, 3u}) {
        const SoilSurface soil(bucket, Fill(0.3, 0.05), seed);
        const double coarse = soil.Volume(0.002);
        const double fine = soil.Volume(0.001);
        EXPECT_LE(std::abs(coarse - area * 0.3), 0.05 * area);
        EXPECT_GT(std::abs(coarse - area * 0.3), 1e-6);  // it is perturbed
        EXPECT_NEAR(coarse, fine, 5e-4 * fine);
    }
}

TEST(SoilSurfaceTest, PerturbationIsBoundedAndSeeded) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kExcavatorBucket);
    const SoilSurface soil(bucket, Fill(0.4, 0.03), 7);
    const SoilSurface same(bucket, Fill(0.4, 0.03), 7);
    const SoilSurface other(bucket, Fill(0.4, 0.03), 8);
    double max_change = 0.0;
    for (double x = -0.6; x <= 0.6; x += 0.013) {
        for (double y = -0.45; y <= 0.45; y += 0.011) {
            const double s = soil.SurfaceZ(x, y);
            const double heap = std::min(0.6 - std::abs(x), 0.5 - std::abs(y));
            if (heap > 0.1) {
                EXPECT_LE(std::abs(s - (0.4 - 0.75)), 0.03 + 1e-12);
            }
            EXPECT_GE(s, soil.SurfaceMinZ() - 1e-12);
            EXPECT_LE(s, soil.SurfaceMaxZ() + 1e-12);
            EXPECT_EQ(s, same.SurfaceZ(x, y));
            max_change = std::max(max_change, std::abs(s - other.SurfaceZ(x, y)));
        }
    }
    EXPECT_GT(max_change, 0.005);
}

TEST(SoilSurfaceTest, ZeroFillIsEmptyDespitePerturbation) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    for (const double h : {0.0, -0.1}) {
        const SoilSurface soil(bucket, Fill(h, 0.05), 1);
        EXPECT_TRUE(soil.Empty());
        EXPECT_EQ(soil.Volume(0.002), 0.0);
        EXPECT_FALSE(soil.Contains({0.0, 0.0, -0.59}));
        EXPECT_EQ(TrueSoilVolume(bucket, Fill(h, 0.05), 1), 0.0);
    }
}

TEST(SoilSurfaceTest, SoilIsOnlyInsideTheContainer) {
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kExcavatorBucket);
    const SoilSurface soil(bucket, Fill(0.3, 0.0), 1);
    EXPECT_TRUE(soil.Contains({0.0, 0.0, -0.5}));
    EXPECT_FALSE(soil.Contains({0.0, 0.0, -0.76}));   // below the floor
    EXPECT_FALSE(soil.Contains({0.0, 0.0, -0.44}));   // above the surface
    EXPECT_FALSE(soil.Contains({0.61, 0.0, -0.5}));   // beside the opening
    EXPECT_FALSE(soil.Contains({0.0, -0.45, -0.5}));  // behind the sloped front wall
}

TEST(SoilSurfaceTest, OverfillFormsTheHeapedCapacity) {
    for (const ContainerKind kind :
         {ContainerKind::kPaperBucket, ContainerKind::kExcavatorBucket, ContainerKind::kTruckBed}) {
        const ContainerGeometry c = MakeContainer(kind);
        for (const double slope : {1.0, 0.5}) {
            SoilSpec soil = Fill(c.depth_m + 5.0, 0.02);
            soil.heap_slope = slope;
            const double expected = HeapedCapacity(c, slope);
            EXPECT_NEAR(TrueSoilVolume(c, soil, 1), expected, 5e-4 * expected)
                << c.name << " slope " << slope;
        }
    }
}

// The truth at 2 mm over a 4 x 2.2 m bed; its time is printed, speed is the benchmarks' to judge
// (a limit here ran at 60% of itself under the sanitizers).
TEST(SoilSurfaceTest, TruckBedTruthIsItsBoxVolume) {
    const ContainerGeometry truck = MakeContainer(ContainerKind::kTruckBed);
    Timer timer;
    const double volume = TrueSoilVolume(truck, Fill(0.5, 0.05), 3);
    const double ms = timer.Lap();
    std::printf("true_volume_truck_bed_ms=%.1f volume_m3=%.4f\n", ms, volume);
    EXPECT_NEAR(volume, 4.0 * 2.2 * 0.5, 0.05 * 4.0 * 2.2);
}

}  // namespace
}  // namespace soilvol::sim
