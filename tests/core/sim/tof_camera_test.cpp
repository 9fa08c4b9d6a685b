#include "core/sim/tof_camera.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <random>

#include "core/sim/tof_sensor.hpp"

namespace soilvol::sim {
namespace {

// The paper bucket a third full, seen from its nominal viewpoint.
struct BucketView {
    ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    SceneRaycaster scene{bucket, SoilSurface(bucket, Soil(), 3)};
    Pose T_scan_container = NominalScanPose(ViewpointFor(ContainerKind::kPaperBucket));

    static SoilSpec Soil() {
        SoilSpec soil;
        soil.fill_height_m = 0.2;
        soil.perturbation_m = 0.03;
        return soil;
    }
};

TofCameraSpec Clean() {
    TofCameraSpec spec;
    spec.noise_at_1m_m = 0.0;
    spec.flying_pixels = false;
    spec.multipath_m = 0.0;
    return spec;
}

// Range along the pixel's ray of the z-depth it returned.
double RangeOf(const TofFrame& frame, std::size_t i) {
    const int u = static_cast<int>(i % frame.depth.width);
    const int v = static_cast<int>(i / frame.depth.width);
    const CameraIntrinsics& k = frame.intrinsics;
    const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    return static_cast<double>(frame.depth.values[i]) * ray.norm();
}

TEST(TofCameraTest, WithoutArtefactsEveryReturnIsItsCentreRaysHit) {
    const BucketView view;
    std::mt19937_64 rng(1);
    const TofFrame frame = RenderTof(view.scene, view.T_scan_container, Clean(), &rng);
    ASSERT_EQ(frame.depth.values.size(), 320u * 240u);
    std::size_t returns = 0;
    for (std::size_t i = 0; i < frame.depth.values.size(); ++i) {
        if (frame.depth.values[i] <= 0.0f) continue;
        ++returns;
        ASSERT_NEAR(RangeOf(frame, i), frame.true_range_m[i],
                    1e-5 * static_cast<double>(frame.true_range_m[i]));
        ASSERT_EQ(frame.mix_share[i], 0.0f);
    }
    EXPECT_GT(returns, frame.depth.values.size() / 10);
}

TEST(TofCameraTest, MixedReturnsLieBetweenTheirSurfaces) {
    const BucketView view;
    TofCameraSpec spec = Clean();
    spec.flying_pixels = true;
    std::mt19937_64 rng(2);
    const TofFrame frame = RenderTof(view.scene, view.T_scan_container, spec, &rng);
    std::size_t mixed = 0;
    for (std::size_t i = 0; i < frame.depth.values.size(); ++i) {
        if (frame.depth.values[i] <= 0.0f) continue;
        const double range = RangeOf(frame, i);
        const double own = static_cast<double>(frame.true_range_m[i]);
        const double share = static_cast<double>(frame.mix_share[i]);
        if (share == 0.0) {
            // The footprint saw one surface (every sub-ray within 3% of the centre's): its mean
            // lies within that spread.
            ASSERT_NEAR(range, own, 0.03 * own) << i;
            continue;
        }
        ++mixed;
        const double other = static_cast<double>(frame.other_range_m[i]);
        ASSERT_GT(share, 0.0);
        ASSERT_LE(share, 1.0);
        // Between its own surface (give or take its spread) and the other surfaces' mean,
        // nearer to the one with the larger share of the light.
        const double low = std::min(own * 0.97, other);
        const double high = std::max(own * 1.03, other);
        ASSERT_GE(range, low) << i;
        ASSERT_LE(range, high) << i;
        ASSERT_NEAR(range, (1.0 - share) * own + share * other, 0.03 * own) << i;
    }
    // The rim against the floor and the ground: hundreds of edge pixels at 320x240.
    EXPECT_GT(mixed, 200u);
}

TEST(TofCameraTest, MultipathPushesLongOnlyNearConcaveCorners) {
    const BucketView view;
    TofCameraSpec spec = Clean();
    spec.multipath_m = 0.02;
    std::mt19937_64 rng(3);
    const TofFrame frame = RenderTof(view.scene, view.T_scan_container, spec, &rng);
    std::size_t biased = 0;
    std::size_t returns = 0;
    for (std::size_t i = 0; i < frame.depth.values.size(); ++i) {
        if (frame.depth.values[i] <= 0.0f) continue;
        ++returns;
        ASSERT_GE(frame.multipath_m[i], 0.0f);
        ASSERT_LE(frame.multipath_m[i], 0.02f + 1e-6f);
        ASSERT_NEAR(RangeOf(frame, i),
                    static_cast<double>(frame.true_range_m[i] + frame.multipath_m[i]), 1e-4);
        biased += frame.multipath_m[i] > 0.01f;
    }
    // Where soil meets the walls, not across the open floor or the outside.
    EXPECT_GT(biased, 50u);
    EXPECT_LT(biased, returns / 4);
}

TEST(TofCameraTest, NoiseGrowsWithRangeAsTheModelSays) {
    const BucketView view;
    TofCameraSpec spec = Clean();
    spec.noise_at_1m_m = 0.004;
    std::mt19937_64 rng(4);
    const TofFrame frame = RenderTof(view.scene, view.T_scan_container, spec, &rng);
    // Normalised residuals (measured - true) / sigma must have unit spread.
    double sum2 = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < frame.depth.values.size(); ++i) {
        if (frame.depth.values[i] <= 0.0f) continue;
        const double r = static_cast<double>(frame.true_range_m[i]);
        const double incidence_cos = static_cast<double>(frame.amplitude.values[i]) * r * r;
        const double sigma = spec.noise_at_1m_m * r / std::sqrt(std::max(incidence_cos, 1e-3));
        const double z = (RangeOf(frame, i) - r) / sigma;
        sum2 += z * z;
        ++n;
    }
    ASSERT_GT(n, 1000u);
    EXPECT_NEAR(std::sqrt(sum2 / static_cast<double>(n)), 1.0, 0.05);
}

TEST(TofCameraTest, TofScenesPlaceTheContainerAsCloudScenesDo) {
    SceneSpec spec;
    spec.sensor = ViewpointFor(ContainerKind::kPaperBucket);
    spec.jitter = {3.0, 0.05};
    spec.soil.fill_height_m = 0.2;
    spec.scan_seed = 9;
    const Scene cloud = SimulateScene(spec);
    const TofScene tof = SimulateTofScene(spec, Clean());
    EXPECT_TRUE(tof.scene.T_scan_container.isApprox(cloud.T_scan_container, 1e-12));
    EXPECT_EQ(tof.scene.true_volume_m3, cloud.true_volume_m3);
    EXPECT_EQ(tof.scene.struck_capacity_m3, cloud.struck_capacity_m3);
    EXPECT_TRUE(tof.scene.points.empty());
    // The camera looks at the container: the opening's centre is in the image, in front.
    const Eigen::Vector3d centre = tof.scene.T_scan_container.translation();
    const CameraIntrinsics& k = tof.frame.intrinsics;
    ASSERT_GT(centre.z(), 0.0);
    const double u = k.fx * centre.x() / centre.z() + k.cx;
    const double v = k.fy * centre.y() / centre.z() + k.cy;
    EXPECT_GT(u, 0.0);
    EXPECT_LT(u, tof.frame.depth.width);
    EXPECT_GT(v, 0.0);
    EXPECT_LT(v, tof.frame.depth.height);
}

}  // namespace
}  // namespace soilvol::sim
