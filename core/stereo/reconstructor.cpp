#include "core/stereo/reconstructor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/stereo/image_codec.hpp"
#include "core/stereo/opencv_camera.hpp"
#include "core/stereo/opencv_image.hpp"

namespace soilvol::stereo {

struct StereoReconstructor::Impl {
    StereoCalibration calibration;
    ReconstructConfig config;
    cv::Mat left_k, left_d, right_k, right_d, r1, p1;
    cv::Mat left_map1, left_map2, right_map1, right_map2;
};

namespace {

GreyImage Remap(const GreyImage& image, const cv::Mat& map1, const cv::Mat& map2) {
    GreyImage out{image.width, image.height,
                  std::vector<uint8_t>(static_cast<std::size_t>(image.width) * image.height)};
    cv::Mat dst = detail::WrapGrey(out);
    cv::remap(detail::WrapGrey(image), dst, map1, map2, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
              cv::Scalar(0));
    return out;
}

absl::Status CheckSize(const GreyImage& image, const StereoParameters& p, const char* name) {
    if (image.width == p.image_width && image.height == p.image_height &&
        image.pixels.size() == static_cast<std::size_t>(image.width) * image.height) {
        return absl::OkStatus();
    }
    return absl::InvalidArgumentError(absl::StrCat(name, ": image is ", image.width, "x",
                                                   image.height, ", the calibration is ",
                                                   p.image_width, "x", p.image_height));
}

// 255 where a pixel lies within `band` px of a disparity jump above `jump` or of a pixel
// without a disparity (only where the pixel itself has one).
cv::Mat EdgeMask(const DisparityMap& map, double jump, int band) {
    cv::Mat edges(map.height, map.width, CV_8UC1, cv::Scalar(0));
    const auto is_edge = [&](float a, float b) {
        return std::isfinite(a) != std::isfinite(b) ||
               (std::isfinite(a) && std::abs(static_cast<double>(a - b)) > jump);
    };
    for (int v = 0; v + 1 < map.height; ++v) {
        for (int u = 0; u + 1 < map.width; ++u) {
            const float d = map.At(u, v);
            if (is_edge(d, map.At(u + 1, v))) {
                edges.at<uint8_t>(v, u) = edges.at<uint8_t>(v, u + 1) = 255;
            }
            if (is_edge(d, map.At(u, v + 1))) {
                edges.at<uint8_t>(v, u) = edges.at<uint8_t>(v + 1, u) = 255;
            }
        }
    }
    if (band > 0) {
        cv::dilate(
            edges, edges,
            cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * band + 1, 2 * band + 1)));
    }
    return edges;
}

// Stride on which at most max_points valid pixels remain.
int StrideFor(std::size_t valid, std::size_t max_points) {
    if (max_points == 0 || valid <= max_points) return 1;
    return static_cast<int>(std::ceil(std::sqrt(static_cast<double>(valid) / max_points)));
}

}  // namespace

StereoReconstructor::StereoReconstructor(std::shared_ptr<const Impl> impl)
    : impl_(std::move(impl)) {}

absl::StatusOr<StereoReconstructor> StereoReconstructor::Create(
    const StereoCalibration& calibration, const ReconstructConfig& config) {
    if (auto status = ValidateSgbmConfig(config.sgbm); !status.ok()) return status;
    if (!(config.min_range_m >= 0.0) || !(config.max_range_m > config.min_range_m) ||
        !std::isfinite(config.max_range_m)) {
        return absl::InvalidArgumentError("max_range_m must be finite and above min_range_m >= 0");
    }
    const StereoParameters& p = calibration.parameters;
    if (p.image_width <= 0 || p.image_height <= 0 || !(calibration.P1(0, 0) > 0.0) ||
        calibration.Q(3, 2) == 0.0 || !calibration.Q.allFinite()) {
        return absl::InvalidArgumentError("calibration is not rectified");
    }
    auto impl = std::make_shared<Impl>();
    impl->calibration = calibration;
    impl->config = config;
    impl->left_k = detail::CameraMatrix(p.left);
    impl->left_d = detail::DistortionRow(p.left);
    impl->right_k = detail::CameraMatrix(p.right);
    impl->right_d = detail::DistortionRow(p.right);
    cv::Mat r2, p2;
    cv::eigen2cv(calibration.R1, impl->r1);
    cv::eigen2cv(calibration.R2, r2);
    cv::eigen2cv(Eigen::Matrix<double, 3, 4>(calibration.P1), impl->p1);
    cv::eigen2cv(Eigen::Matrix<double, 3, 4>(calibration.P2), p2);
    const cv::Size size(p.image_width, p.image_height);
    try {
        cv::initUndistortRectifyMap(impl->left_k, impl->left_d, impl->r1, impl->p1, size, CV_16SC2,
                                    impl->left_map1, impl->left_map2);
        cv::initUndistortRectifyMap(impl->right_k, impl->right_d, r2, p2, size, CV_16SC2,
                                    impl->right_map1, impl->right_map2);
    } catch (const cv::Exception& e) {
        return absl::InvalidArgumentError(absl::StrCat("rectification maps: ", e.what()));
    }
    return StereoReconstructor(std::move(impl));
}

absl::StatusOr<StereoCloud> StereoReconstructor::Reconstruct(std::string_view left,
                                                             std::string_view right,
                                                             PixelRect region,
                                                             const StopToken& stop) const {
    Timer timer;
    const int max_side = impl_->config.max_image_side_px;
    SOILVOL_RETURN_IF_ERROR(stop.Check("image decoding"));
    absl::StatusOr<GreyImage> left_image = DecodeGrey(left, "left", max_side);
    if (!left_image.ok()) return left_image.status();
    SOILVOL_RETURN_IF_ERROR(stop.Check("image decoding"));
    absl::StatusOr<GreyImage> right_image = DecodeGrey(right, "right", max_side);
    if (!right_image.ok()) return right_image.status();
    const double decode_ms = timer.Lap();
    absl::StatusOr<StereoCloud> cloud = Reconstruct(*left_image, *right_image, region, stop);
    if (cloud.ok()) cloud->timings.decode_ms = decode_ms;
    return cloud;
}

absl::StatusOr<StereoCloud> StereoReconstructor::Reconstruct(const GreyImage& left,
                                                             const GreyImage& right,
                                                             PixelRect region,
                                                             const StopToken& stop) const {
    const StereoParameters& p = impl_->calibration.parameters;
    if (auto status = CheckSize(left, p, "left"); !status.ok()) return status;
    if (auto status = CheckSize(right, p, "right"); !status.ok()) return status;
    StereoCloud cloud;
    Timer timer;
    // Sec. 3.1: rectify, match, reproject.
    SOILVOL_RETURN_IF_ERROR(stop.Check("rectification"));
    const GreyImage left_rectified = Remap(left, impl_->left_map1, impl_->left_map2);
    const GreyImage right_rectified = Remap(right, impl_->right_map1, impl_->right_map2);
    cloud.timings.rectify_ms = timer.Lap();
    absl::StatusOr<DisparityMap> disparity =
        ComputeDisparity(left_rectified, right_rectified, impl_->config.sgbm, region, stop);
    if (!disparity.ok()) return disparity.status();
    cloud.disparity = *std::move(disparity);
    cloud.timings.match_ms = timer.Lap();
    SOILVOL_RETURN_IF_ERROR(stop.Check("reprojection"));

    const ReconstructConfig& config = impl_->config;
    // Disparities below this are beyond max_range_m (also in the least favourable corner).
    const double min_disparity =
        impl_->calibration.focal_px * impl_->calibration.baseline_m / config.max_range_m;
    std::size_t in_range = 0;
    for (const float d : cloud.disparity.values) in_range += static_cast<double>(d) > min_disparity;
    cloud.stride = StrideFor(in_range, config.max_points);
    const double min2 = config.min_range_m * config.min_range_m;
    const double max2 = config.max_range_m * config.max_range_m;
    cloud.points.reserve(cloud.disparity.valid / (cloud.stride * cloud.stride) + 1);
    const int band = config.edge_band_px < 0 ? config.sgbm.block_size / 2 : config.edge_band_px;
    const cv::Mat edges =
        config.edge_jump_px > 0.0
            ? EdgeMask(cloud.disparity, config.edge_jump_px, band)
            : cv::Mat(cloud.disparity.height, cloud.disparity.width, CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < cloud.disparity.height; v += cloud.stride) {
        for (int u = 0; u < cloud.disparity.width; u += cloud.stride) {
            const float d = cloud.disparity.At(u, v);
            if (!(d > 0.0f) || edges.at<uint8_t>(v, u) != 0) continue;
            const Eigen::Vector3d point = Reproject(u, v, static_cast<double>(d));
            const double range2 = point.squaredNorm();
            if (!std::isfinite(range2) || range2 < min2 || range2 > max2) continue;
            cloud.points.push_back(point.cast<float>());
        }
    }
    cloud.timings.reproject_ms = timer.Lap();
    return cloud;
}

Eigen::Vector2d StereoReconstructor::RectifyLeftPixel(const Eigen::Vector2d& raw_px) const {
    std::vector<cv::Point2d> in{{raw_px.x(), raw_px.y()}};
    std::vector<cv::Point2d> out;
    cv::undistortPoints(in, out, impl_->left_k, impl_->left_d, impl_->r1, impl_->p1);
    return {out[0].x, out[0].y};
}

Eigen::Vector2d StereoReconstructor::ProjectRectified(const Eigen::Vector3d& point) const {
    if (!(point.z() > 0.0)) {
        return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    }
    const Eigen::Vector3d h = impl_->calibration.P1 * point.homogeneous();
    return h.hnormalized();
}

Eigen::Vector3d StereoReconstructor::Reproject(double u, double v, double d) const {
    const Eigen::Vector4d h = impl_->calibration.Q * Eigen::Vector4d(u, v, d, 1.0);
    return h.hnormalized();
}

PixelRect StereoReconstructor::RegionOf(const Cloud& points, const Pose& T_rectified_points,
                                        int margin_px) const {
    Eigen::AlignedBox2d box;
    for (const Eigen::Vector3f& point : points) {
        const Eigen::Vector2d px = ProjectRectified(T_rectified_points * point.cast<double>());
        if (px.allFinite()) box.extend(px);
    }
    if (box.isEmpty()) return {};
    const StereoParameters& p = impl_->calibration.parameters;
    const PixelRect tight{static_cast<int>(std::max(std::floor(box.min().x()), -1e6)),
                          static_cast<int>(std::max(std::floor(box.min().y()), -1e6)),
                          static_cast<int>(std::min(std::ceil(box.max().x()) + 1, 1e6)),
                          static_cast<int>(std::min(std::ceil(box.max().y()) + 1, 1e6))};
    const PixelRect rect = tight.Grown(margin_px, p.image_width, p.image_height);
    return rect.Empty() ? PixelRect{} : rect;
}

const StereoCalibration& StereoReconstructor::calibration() const { return impl_->calibration; }
const ReconstructConfig& StereoReconstructor::config() const { return impl_->config; }

}  // namespace soilvol::stereo
