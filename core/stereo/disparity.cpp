#include "core/stereo/disparity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"
#include "core/stereo/opencv_image.hpp"

namespace soilvol::stereo {
namespace {

int Mode(SgbmMode mode) {
    switch (mode) {
        case SgbmMode::kSgbm:
            return cv::StereoSGBM::MODE_SGBM;
        case SgbmMode::kHh:
            return cv::StereoSGBM::MODE_HH;
        case SgbmMode::kHh4:
            return cv::StereoSGBM::MODE_HH4;
        case SgbmMode::kSgbm3Way:
            break;
    }
    return cv::StereoSGBM::MODE_SGBM_3WAY;
}

absl::Status CheckImage(const GreyImage& image, const char* name) {
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != static_cast<std::size_t>(image.width) * image.height) {
        return absl::InvalidArgumentError(absl::StrCat(name, ": empty or inconsistent image"));
    }
    return absl::OkStatus();
}

// The region grown by a matching margin, clipped to the image; to the left it also takes the
// columns the search range reaches into.
cv::Rect Matched(PixelRect region, const SgbmConfig& config, int width, int height) {
    if (region.Empty()) return {0, 0, width, height};
    const PixelRect grown = region.Grown(config.block_size / 2 + 8, width, height);
    const int reach = config.min_disparity + config.num_disparities;
    const int u0 = std::max(grown.u0 - std::max(reach, 0), 0);
    return {u0, grown.v0, grown.u1 - u0, grown.v1 - grown.v0};
}

}  // namespace

absl::Status ValidateSgbmConfig(const SgbmConfig& config) {
    if (config.num_disparities <= 0 || config.num_disparities % 16 != 0 ||
        config.num_disparities > 1024) {
        return absl::InvalidArgumentError(
            "num_disparities must be a positive multiple of 16, <= 1024");
    }
    if (std::abs(config.min_disparity) > 1024) {
        return absl::InvalidArgumentError("min_disparity must be within [-1024, 1024]");
    }
    if (config.block_size < 1 || config.block_size % 2 == 0 || config.block_size > 31) {
        return absl::InvalidArgumentError("block_size must be odd, in [1, 31]");
    }
    if (config.p1 < 0 || config.p2 < 0 || (config.p2 > 0 && config.p2 <= config.p1)) {
        return absl::InvalidArgumentError("p1 and p2 must be >= 0 with p2 > p1");
    }
    if (config.uniqueness_ratio < 0 || config.uniqueness_ratio > 100 || config.pre_filter_cap < 1 ||
        config.pre_filter_cap > 63 || config.speckle_window_size < 0 || config.speckle_range < 0) {
        return absl::InvalidArgumentError(
            "uniqueness_ratio must be in [0, 100], pre_filter_cap in [1, 63], speckle figures >= "
            "0");
    }
    return absl::OkStatus();
}

absl::StatusOr<DisparityMap> ComputeDisparity(const GreyImage& left_rectified,
                                              const GreyImage& right_rectified,
                                              const SgbmConfig& config, PixelRect region) {
    if (auto status = ValidateSgbmConfig(config); !status.ok()) return status;
    if (auto status = CheckImage(left_rectified, "left"); !status.ok()) return status;
    if (auto status = CheckImage(right_rectified, "right"); !status.ok()) return status;
    if (left_rectified.width != right_rectified.width ||
        left_rectified.height != right_rectified.height) {
        return absl::InvalidArgumentError(absl::StrCat(
            "image sizes differ: left ", left_rectified.width, "x", left_rectified.height,
            ", right ", right_rectified.width, "x", right_rectified.height));
    }
    const int width = left_rectified.width;
    const int height = left_rectified.height;
    const cv::Rect matched = Matched(region, config, width, height);
    const PixelRect kept = region.Empty() ? PixelRect{0, 0, width, height} : region;

    DisparityMap map;
    map.width = width;
    map.height = height;
    map.values.assign(static_cast<std::size_t>(width) * height,
                      std::numeric_limits<float>::quiet_NaN());
    if (matched.width <= 0 || matched.height <= 0) return map;

    const int area = config.block_size * config.block_size;
    const int p1 = config.p1 > 0 ? config.p1 : 8 * area;
    const int p2 = config.p2 > 0 ? config.p2 : 32 * area;
    cv::Mat disparity;
    try {
        cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
            config.min_disparity, config.num_disparities, config.block_size, p1,
            std::max(p2, p1 + 1), config.disp12_max_diff, config.pre_filter_cap,
            config.uniqueness_ratio, config.speckle_window_size, config.speckle_range,
            Mode(config.mode));
        sgbm->compute(detail::WrapGrey(left_rectified)(matched),
                      detail::WrapGrey(right_rectified)(matched), disparity);
    } catch (const cv::Exception& e) {
        return absl::InternalError(absl::StrCat("stereo matching failed: ", e.what()));
    }
    // Fixed point with 4 fractional bits; below min_disparity means no match.
    const int invalid_below = config.min_disparity * 16;
    for (int v = std::max(kept.v0, matched.y); v < std::min(kept.v1, matched.y + matched.height);
         ++v) {
        const int16_t* row = disparity.ptr<int16_t>(v - matched.y);
        float* out = &map.values[static_cast<std::size_t>(v) * width];
        for (int u = std::max(kept.u0, matched.x); u < std::min(kept.u1, matched.x + matched.width);
             ++u) {
            const int16_t d = row[u - matched.x];
            if (d < invalid_below) continue;
            out[u] = d / 16.0f;
            ++map.valid;
        }
    }
    return map;
}

}  // namespace soilvol::stereo
