// The flying-pixel filter against the simulated ToF camera, which integrates each pixel's
// footprint and so knows every mixed return: the rims of the three container families over
// their soil and the ground behind them, with multipath in the corners.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <random>
#include <vector>

#include "core/depth/flying_pixels.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"
#include "core/sim/tof_camera.hpp"
#include "core/sim/tof_sensor.hpp"

namespace soilvol::depth {
namespace {

struct Tally {
    std::size_t mixed = 0;  ///< mixed returns more than kApart sigmas off both their surfaces
    std::size_t mixed_removed = 0;
    std::size_t pure = 0;  ///< returns of one surface
    std::size_t pure_kept = 0;

    void Add(const Tally& t) {
        mixed += t.mixed;
        mixed_removed += t.mixed_removed;
        pure += t.pure;
        pure_kept += t.pure_kept;
    }
};

// The range the pixel's z-depth means, along its centre ray.
double RangeOf(const sim::TofFrame& frame, std::size_t i) {
    const int u = static_cast<int>(i % static_cast<std::size_t>(frame.depth.width));
    const int v = static_cast<int>(i / static_cast<std::size_t>(frame.depth.width));
    const CameraIntrinsics& k = frame.intrinsics;
    const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    return static_cast<double>(frame.depth.values[i]) * ray.norm();
}

// The rendered frame of `kind` a third full, from its nominal viewpoint.
sim::TofFrame Render(sim::ContainerKind kind, std::uint64_t seed, const sim::TofCameraSpec& spec) {
    const sim::ContainerGeometry container = sim::MakeContainer(kind);
    sim::SoilSpec soil;
    soil.fill_height_m = 0.35 * container.depth_m;
    soil.perturbation_m = 0.04;
    const sim::SceneRaycaster scene(container, sim::SoilSurface(container, soil, seed));
    std::mt19937_64 rng(seed);
    return sim::RenderTof(scene, sim::NominalScanPose(sim::ViewpointFor(kind)), spec, &rng);
}

// Mixed returns count when they lie more than `apart` of the pixel's noise sigmas off both
// surfaces (nearer, the noise hides the mix from any filter, and from the volume).
Tally Judge(const sim::TofFrame& frame, const sim::TofCameraSpec& spec, double apart) {
    std::vector<float> z = frame.depth.values;
    for (float& value : z) {
        if (value <= 0.0f) value = std::nanf("");
    }
    FlyingPixelConfig config;
    config.noise_at_1m_m = spec.noise_at_1m_m;
    const auto flying = FindFlyingPixels(z, frame.depth.width, frame.depth.height, config);
    Tally tally;
    for (std::size_t i = 0; i < z.size(); ++i) {
        if (!(z[i] > 0.0f)) continue;
        if (frame.mix_share[i] == 0.0f) {
            ++tally.pure;
            tally.pure_kept += flying[i] == 0;
            continue;
        }
        const double range = RangeOf(frame, i);
        const double r = static_cast<double>(frame.true_range_m[i]);
        const double incidence_cos = static_cast<double>(frame.amplitude.values[i]) * r * r;
        const double sigma = spec.noise_at_1m_m * range / std::sqrt(std::max(incidence_cos, 1e-3));
        const double own = r + static_cast<double>(frame.multipath_m[i]);
        const double other = static_cast<double>(frame.other_range_m[i]);
        if (std::abs(range - own) <= apart * sigma || std::abs(range - other) <= apart * sigma) {
            continue;
        }
        ++tally.mixed;
        tally.mixed_removed += flying[i] != 0;
    }
    return tally;
}

double Share(std::size_t part, std::size_t whole) {
    return static_cast<double>(part) / static_cast<double>(whole);
}

TEST(FlyingPixelsTofTest, RemovesMixedReturnsAndKeepsSurfacesOnEveryFamily) {
    sim::TofCameraSpec spec;
    spec.width = 640;
    spec.height = 480;
    spec.multipath_m = 0.02;
    for (const auto kind : {sim::ContainerKind::kPaperBucket, sim::ContainerKind::kExcavatorBucket,
                            sim::ContainerKind::kTruckBed}) {
        Tally three, five;
        for (std::uint64_t seed = 1; seed <= 3; ++seed) {
            const sim::TofFrame frame = Render(kind, seed, spec);
            three.Add(Judge(frame, spec, 3.0));
            five.Add(Judge(frame, spec, 5.0));
        }
        std::printf(
            "family %d: pure %zu kept %.4f; mixed >3 sigma %zu removed %.4f; >5 sigma %zu "
            "removed %.4f\n",
            static_cast<int>(kind), three.pure, Share(three.pure_kept, three.pure), three.mixed,
            Share(three.mixed_removed, three.mixed), five.mixed,
            Share(five.mixed_removed, five.mixed));
        ASSERT_GT(three.mixed, 300u);
        EXPECT_GE(Share(three.pure_kept, three.pure), 0.99);
        EXPECT_GE(Share(five.mixed_removed, five.mixed), 0.95);
    }
}

}  // namespace
}  // namespace soilvol::depth
