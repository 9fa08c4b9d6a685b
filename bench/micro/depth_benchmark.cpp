// Depth images (issue 29's target: decode and back-project a 640x480 image in <= 3 ms): a
// tilted floor with a box standing on it, 16-bit PNG in millimetres and 32-bit float TIFF,
// through DecodeDepthScan (header check, decode, rays from the cache, z or range, the
// flying-pixel filter, back-projection), and the stages alone.
#include <benchmark/benchmark.h>

#include <cmath>
#include <string>

#include "core/depth/depth_scan.hpp"
#include "core/depth/ray_table.hpp"
#include "core/stereo/image_codec.hpp"

namespace soilvol::bench {
namespace {

constexpr int kWidth = 640;
constexpr int kHeight = 480;

depth::DepthCamera Camera(bool distorted) {
    depth::DepthCamera camera;
    camera.intrinsics = {525.0, 525.0, 319.5, 239.5, {}};
    if (distorted) {
        camera.lens = depth::LensModel::kBrownConrady;
        camera.intrinsics.distortion = {-0.28, 0.09, 0.001, -0.0007, -0.012};
    }
    return camera;
}

// Z-depth [m]: a floor 3 m away tilted 20 deg, a 0.5 m box in the middle third.
ScalarImage Scene(double unit) {
    ScalarImage image{kWidth, kHeight, unit < 1.0 ? 16 : 32, {}};
    image.values.reserve(static_cast<size_t>(kWidth) * kHeight);
    for (int v = 0; v < kHeight; ++v) {
        for (int u = 0; u < kWidth; ++u) {
            const double y = (v - 239.5) / 525.0;
            double z = 3.0 / (1.0 + std::tan(20.0 * M_PI / 180.0) * y);
            if (u > kWidth / 3 && u < 2 * kWidth / 3 && v > kHeight / 3 && v < 2 * kHeight / 3) {
                z -= 0.5;
            }
            image.values.push_back(static_cast<float>(z / unit));
        }
    }
    return image;
}

const std::string& Encoded(int bits) {
    static const std::string png = *stereo::EncodeScalar(Scene(0.001));
    static const std::string tiff = *stereo::EncodeScalar(Scene(1.0));
    return bits == 16 ? png : tiff;
}

// state.range(0): 16 (PNG) or 32 (TIFF); state.range(1): a distorted lens.
void BM_DecodeDepthScan(benchmark::State& state) {
    const std::string& bytes = Encoded(static_cast<int>(state.range(0)));
    const depth::DepthCamera camera = Camera(state.range(1) != 0);
    const depth::DepthScanConfig config;
    benchmark::DoNotOptimize(depth::RaysOf(camera, kWidth, kHeight));  // cached, as in service
    for (auto _ : state) {
        auto cloud = depth::DecodeDepthScan(bytes, "", camera, config, "scan.depth");
        if (!cloud.ok()) state.SkipWithError(std::string(cloud.status().message()).c_str());
        benchmark::DoNotOptimize(cloud);
    }
    state.counters["bytes"] = static_cast<double>(bytes.size());
}

void BM_DecodeOnly(benchmark::State& state) {
    const std::string& bytes = Encoded(static_cast<int>(state.range(0)));
    for (auto _ : state) benchmark::DoNotOptimize(stereo::DecodeScalar(bytes, "depth"));
}

void BM_BackProject(benchmark::State& state) {
    const ScalarImage image = Scene(0.001);
    const depth::DepthCamera camera = Camera(state.range(1) != 0);
    depth::DepthScanConfig config;
    config.flying.enabled = state.range(0) != 0;
    benchmark::DoNotOptimize(depth::RaysOf(camera, kWidth, kHeight));  // cached, as in service
    for (auto _ : state) {
        benchmark::DoNotOptimize(depth::BackProject(image, nullptr, camera, config, "depth"));
    }
}

// The first call for a camera: every pixel's ray through OpenCV's lens inversion.
void BM_RayTable(benchmark::State& state) {
    depth::DepthCamera camera = Camera(true);
    double fx = 525.0;
    for (auto _ : state) {
        camera.intrinsics.fx = (fx += 1e-6);  // a new camera each time: no cache hit
        benchmark::DoNotOptimize(depth::RaysOf(camera, kWidth, kHeight));
    }
}

BENCHMARK(BM_DecodeDepthScan)
    ->Args({16, 0})
    ->Args({16, 1})
    ->Args({32, 0})
    ->ArgNames({"bits", "distorted"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_DecodeOnly)->Arg(16)->Arg(32)->ArgName("bits")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_BackProject)
    ->Args({0, 0})
    ->Args({1, 0})
    ->Args({1, 1})
    ->ArgNames({"flying_filter", "distorted"})
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RayTable)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace soilvol::bench
