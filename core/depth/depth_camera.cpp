#include "core/depth/depth_camera.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>

#include "absl/strings/str_cat.h"

namespace soilvol::depth {
namespace {

bool CountFits(LensModel lens, std::size_t count) {
    switch (lens) {
        case LensModel::kPinhole:
            return count == 0;
        case LensModel::kBrownConrady:
            return count == 4 || count == 5 || count == 8;
        case LensModel::kKannalaBrandt:
            return count == 4;
    }
    return false;
}

const char* CountsOf(LensModel lens) {
    switch (lens) {
        case LensModel::kPinhole:
            return "none";
        case LensModel::kBrownConrady:
            return "4, 5 or 8 (k1, k2, p1, p2[, k3[, k4, k5, k6]])";
        case LensModel::kKannalaBrandt:
            return "4 (k1, k2, k3, k4)";
    }
    return "none";
}

}  // namespace

double DepthUnitOf(const DepthCamera& camera, int bits) {
    if (camera.depth_unit_m > 0.0) return camera.depth_unit_m;
    return bits == 32 ? 1.0 : 0.001;
}

absl::Status ValidateDepthCamera(const DepthCamera& camera, int width, int height,
                                 std::string_view field) {
    const absl::string_view name(field.data(), field.size());
    const CameraIntrinsics& k = camera.intrinsics;
    const auto focal_ok = [](double f) { return f >= kMinFocalPx && f <= kMaxFocalPx; };
    if (!focal_ok(k.fx) || !focal_ok(k.fy)) {
        return absl::InvalidArgumentError(absl::StrCat(name, ".fx/fy: focal lengths must lie in [",
                                                       kMinFocalPx, ", ", kMaxFocalPx, "] px (got ",
                                                       k.fx, ", ", k.fy, ")"));
    }
    const double reach = 10.0 * std::max(width, height);
    if (!std::isfinite(k.cx) || !std::isfinite(k.cy) || std::abs(k.cx) > reach ||
        std::abs(k.cy) > reach) {
        return absl::InvalidArgumentError(absl::StrCat(name, ".cx/cy: the principal point (", k.cx,
                                                       ", ", k.cy, ") must be finite and near the ",
                                                       width, "x", height, " image"));
    }
    if (!CountFits(camera.lens, k.distortion.size())) {
        return absl::InvalidArgumentError(absl::StrCat(name, ".distortion: ", k.distortion.size(),
                                                       " coefficients; this lens model takes ",
                                                       CountsOf(camera.lens)));
    }
    for (double c : k.distortion) {
        if (!std::isfinite(c)) {
            return absl::InvalidArgumentError(
                absl::StrCat(name, ".distortion: coefficients must be finite"));
        }
    }
    if (!std::isfinite(camera.depth_unit_m) || camera.depth_unit_m < 0.0) {
        return absl::InvalidArgumentError(absl::StrCat(
            name, ".depth_unit_m: must be finite and >= 0 (0: the image type's default), got ",
            camera.depth_unit_m));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::depth
