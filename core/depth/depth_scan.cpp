#include "core/depth/depth_scan.hpp"

#include <cmath>
#include <memory>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/depth/ray_table.hpp"
#include "core/stereo/image_codec.hpp"

namespace soilvol::depth {
namespace {

absl::Status CheckImages(const ScalarImage& depth, const ScalarImage* confidence,
                         absl::string_view field) {
    if (depth.bits != 16 && depth.bits != 32) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".depth: ", depth.bits,
                         "-bit samples; a depth image stores 16-bit integers or 32-bit floats"));
    }
    if (depth.width <= 0 || depth.height <= 0 ||
        depth.values.size() != static_cast<std::size_t>(depth.width) * depth.height) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".depth: empty or inconsistent image"));
    }
    if (confidence != nullptr &&
        (confidence->width != depth.width || confidence->height != depth.height ||
         confidence->values.size() != depth.values.size())) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".confidence: ", confidence->width, "x", confidence->height,
                         " does not match the depth image's ", depth.width, "x", depth.height));
    }
    return absl::OkStatus();
}

// Each pixel's z-depth [m] (0 where there is no return or too little confidence), counting
// why. Only range images need the rays here (z = range / |ray|); a z image is read as stored.
std::vector<float> ZDepths(const ScalarImage& depth, const ScalarImage* confidence,
                           const DepthCamera& camera, const RayTable& rays,
                           const DepthScanConfig& config, DepthScanCounts& counts) {
    const float unit = static_cast<float>(DepthUnitOf(camera, depth.bits));
    const auto min_confidence = static_cast<float>(config.min_confidence);
    const bool is_range = camera.meaning == DepthMeaning::kRange;
    std::vector<float> z(depth.values.size(), 0.0f);
    for (std::size_t i = 0; i < depth.values.size(); ++i) {
        const float value = depth.values[i] * unit;
        if (!(value > 0.0f) || !std::isfinite(value)) {
            ++counts.no_return;
            continue;
        }
        if (confidence != nullptr && confidence->values[i] < min_confidence) {
            ++counts.low_confidence;
            continue;
        }
        if (!is_range) {
            z[i] = value;
            continue;
        }
        const Eigen::Vector2f& ray = rays.At(static_cast<int>(i));
        const float pixel_z = value / std::sqrt(1.0f + ray.squaredNorm());
        if (std::isfinite(ray.x()) && !(pixel_z > 0.0f)) {  // a sub-normal range, far off axis
            ++counts.out_of_range;
            continue;
        }
        z[i] = pixel_z;  // NaN without a ray: counted when the points are made
    }
    return z;
}

}  // namespace

absl::StatusOr<DepthCloud> BackProject(const ScalarImage& depth, const ScalarImage* confidence,
                                       const DepthCamera& camera, const DepthScanConfig& config,
                                       std::string_view field) {
    const absl::string_view name(field.data(), field.size());
    SOILVOL_RETURN_IF_ERROR(CheckImages(depth, confidence, name));
    SOILVOL_RETURN_IF_ERROR(
        ValidateDepthCamera(camera, depth.width, depth.height, absl::StrCat(name, ".camera")));
    SOILVOL_ASSIGN_OR_RETURN(std::shared_ptr<const RayTable> rays,
                             RaysOf(camera, depth.width, depth.height));
    DepthCloud out;
    out.width = depth.width;
    out.height = depth.height;
    out.counts.pixels = depth.values.size();
    const std::vector<float> z = ZDepths(depth, confidence, camera, *rays, config, out.counts);
    const std::vector<std::uint8_t> flying =
        FindFlyingPixels(z, depth.width, depth.height, config.flying);
    // The filter sees every return, the range cut's too: edges are where the scene has them.
    const auto min_range = static_cast<float>(config.min_range_m);
    const auto max_range = static_cast<float>(config.max_range_m);
    out.points.reserve(z.size());
    out.pixel.reserve(z.size());
    for (std::size_t i = 0; i < z.size(); ++i) {
        const float pixel_z = z[i];
        if (pixel_z == 0.0f) continue;  // counted by ZDepths
        const Eigen::Vector2f& ray = rays->At(static_cast<int>(i));
        if (!std::isfinite(ray.x()) || !std::isfinite(pixel_z)) {
            ++out.counts.no_ray;
            continue;
        }
        if (flying[i] != 0) {
            ++out.counts.flying;
            continue;
        }
        const Eigen::Vector3f point(ray.x() * pixel_z, ray.y() * pixel_z, pixel_z);
        const float range = point.norm();
        if (!(range >= min_range && range <= max_range)) {
            ++out.counts.out_of_range;
            continue;
        }
        out.points.push_back(point);
        out.pixel.push_back(static_cast<std::int32_t>(i));
    }
    return out;
}

absl::StatusOr<DepthCloud> DecodeDepthScan(std::string_view depth_bytes,
                                           std::string_view confidence_bytes,
                                           const DepthCamera& camera, const DepthScanConfig& config,
                                           std::string_view field) {
    const std::string name(field);
    SOILVOL_ASSIGN_OR_RETURN(
        ScalarImage depth, stereo::DecodeScalar(depth_bytes, name + ".depth", config.max_side_px));
    if (confidence_bytes.empty()) return BackProject(depth, nullptr, camera, config, field);
    SOILVOL_ASSIGN_OR_RETURN(
        ScalarImage confidence,
        stereo::DecodeScalar(confidence_bytes, name + ".confidence", config.max_side_px));
    return BackProject(depth, &confidence, camera, config, field);
}

}  // namespace soilvol::depth
