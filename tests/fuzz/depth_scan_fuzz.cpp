// libFuzzer: a depth scan's own logic on hostile numbers: the camera's validation, the pixel
// rays (OpenCV's lens inversion checked by a round trip), the units, the confidence and range
// cuts and the flying-pixel filter. The image decoders are OpenCV's behind the header reader
// that fuzz_image_header covers; here the decoded samples come straight from the input:
//   byte 0, 1      width, height (1-40 px)
//   byte 2         bit 0: float samples (else 16-bit), bits 1-2: lens model, bit 3: range (else
//                  z), bit 4: a confidence image, bit 5: flying-pixel filter off
//   9 doubles      fx, fy, cx, cy, four distortion coefficients (the count the model takes),
//                  the depth unit
//   samples        depth (2 or 4 bytes each), then confidence (1 byte each); missing bytes are 0
// Whatever it accepts must hold: finite points, each from its own pixel, in range, and every
// pixel accounted for exactly once.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "core/depth/depth_scan.hpp"

namespace {

using namespace soilvol;

struct Reader {
    const uint8_t* data;
    size_t size;
    size_t at = 0;

    template <typename T>
    T Next() {
        T value{};
        const size_t n = at < size ? std::min(sizeof(T), size - at) : 0;
        if (n > 0) std::memcpy(&value, data + at, n);
        at += sizeof(T);
        return value;
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    Reader in{data, size};
    const int width = 1 + in.Next<uint8_t>() % 40;
    const int height = 1 + in.Next<uint8_t>() % 40;
    const auto flags = in.Next<uint8_t>();
    depth::DepthCamera camera;
    camera.lens = static_cast<depth::LensModel>(((flags >> 1) & 3) % 3);
    camera.meaning = (flags & 8) != 0 ? depth::DepthMeaning::kRange : depth::DepthMeaning::kZ;
    CameraIntrinsics& k = camera.intrinsics;
    k.fx = in.Next<double>();
    k.fy = in.Next<double>();
    k.cx = in.Next<double>();
    k.cy = in.Next<double>();
    for (int i = 0; i < 4; ++i) {
        const double c = in.Next<double>();
        if (camera.lens != depth::LensModel::kPinhole) k.distortion.push_back(c);
    }
    camera.depth_unit_m = in.Next<double>();

    const int bits = (flags & 1) != 0 ? 32 : 16;
    ScalarImage depth_image{width, height, bits, {}};
    ScalarImage confidence{width, height, 8, {}};
    for (int i = 0; i < width * height; ++i) {
        depth_image.values.push_back(bits == 32 ? in.Next<float>()
                                                : static_cast<float>(in.Next<uint16_t>()));
    }
    for (int i = 0; i < width * height; ++i) {
        confidence.values.push_back(static_cast<float>(in.Next<uint8_t>()));
    }
    depth::DepthScanConfig config;
    config.min_confidence = 10.0;
    config.flying.enabled = (flags & 32) == 0;
    const bool with_confidence = (flags & 16) != 0;

    const auto cloud = depth::BackProject(depth_image, with_confidence ? &confidence : nullptr,
                                          camera, config, "scan.depth");
    if (!cloud.ok()) {
        if (cloud.status().code() != absl::StatusCode::kInvalidArgument) std::abort();
        return 0;
    }
    const depth::DepthScanCounts& n = cloud->counts;
    if (cloud->points.size() != cloud->pixel.size()) std::abort();
    if (n.pixels != static_cast<size_t>(width) * height) std::abort();
    if (cloud->points.size() + n.no_return + n.low_confidence + n.out_of_range + n.no_ray +
            n.flying !=
        n.pixels) {
        std::abort();
    }
    int32_t previous = -1;
    for (size_t i = 0; i < cloud->points.size(); ++i) {
        const Eigen::Vector3f& p = cloud->points[i];
        if (!p.allFinite() || !(p.z() > 0.0f)) std::abort();
        const double range = p.cast<double>().norm();
        if (range < config.min_range_m * 0.999 || range > config.max_range_m * 1.001) std::abort();
        if (cloud->pixel[i] <= previous || cloud->pixel[i] >= width * height) std::abort();
        previous = cloud->pixel[i];
    }
    return 0;
}
