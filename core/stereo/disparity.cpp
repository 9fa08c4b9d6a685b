#include "core/stereo/disparity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
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

// Matches `matched` of both images (CV_16S disparities of its size). A larger area than a band
// is matched band by band: each band's rows plus the margin on either side, keeping its own
// rows (path aggregation and speckle filtering see past the band's edge by the margin).
absl::StatusOr<cv::Mat> Match(const cv::Ptr<cv::StereoSGBM>& sgbm, const cv::Mat& left,
                              const cv::Mat& right, const cv::Rect& matched,
                              const SgbmConfig& config, const StopToken& stop) {
    cv::Mat disparity;
    const std::int64_t area = static_cast<std::int64_t>(matched.width) * matched.height;
    if (area <= config.max_band_pixels) {
        SOILVOL_RETURN_IF_ERROR(stop.Check("stereo matching"));
        sgbm->compute(left(matched), right(matched), disparity);
        return disparity;
    }
    disparity.create(matched.size(), CV_16S);
    const auto most = static_cast<int>(std::min<std::int64_t>(
        (area + config.max_band_pixels - 1) / config.max_band_pixels, matched.height));
    const int band_rows = (matched.height + most - 1) / most;
    const int bands = (matched.height + band_rows - 1) / band_rows;
    for (int y0 = 0, band = 1; y0 < matched.height; y0 += band_rows, ++band) {
        SOILVOL_RETURN_IF_ERROR(
            stop.Check(absl::StrCat("stereo matching (band ", band, " of ", bands, ")")));
        const int y1 = std::min(y0 + band_rows, matched.height);
        const int top = std::max(y0 - config.band_margin_px, 0);
        const int bottom = std::min(y1 + config.band_margin_px, matched.height);
        const cv::Rect rows(matched.x, matched.y + top, matched.width, bottom - top);
        cv::Mat band_disparity;
        sgbm->compute(left(rows), right(rows), band_disparity);
        band_disparity.rowRange(y0 - top, y1 - top).copyTo(disparity.rowRange(y0, y1));
    }
    return disparity;
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
    if (config.max_band_pixels < 1 || config.band_margin_px < 0) {
        return absl::InvalidArgumentError(
            "max_band_pixels must be positive and band_margin_px >= 0");
    }
    return absl::OkStatus();
}

absl::StatusOr<DisparityMap> ComputeDisparity(const GreyImage& left_rectified,
                                              const GreyImage& right_rectified,
                                              const SgbmConfig& config, PixelRect region,
                                              const StopToken& stop) {
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
    absl::StatusOr<cv::Mat> matched_disparity;
    try {
        cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
            config.min_disparity, config.num_disparities, config.block_size, p1,
            std::max(p2, p1 + 1), config.disp12_max_diff, config.pre_filter_cap,
            config.uniqueness_ratio, config.speckle_window_size, config.speckle_range,
            Mode(config.mode));
        matched_disparity = Match(sgbm, detail::WrapGrey(left_rectified),
                                  detail::WrapGrey(right_rectified), matched, config, stop);
    } catch (const cv::Exception& e) {
        return absl::InternalError(absl::StrCat("stereo matching failed: ", e.what()));
    }
    if (!matched_disparity.ok()) return matched_disparity.status();
    const cv::Mat& disparity = *matched_disparity;
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
