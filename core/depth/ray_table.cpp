#include "core/depth/ray_table.hpp"

#include <cmath>
#include <cstddef>
#include <list>
#include <mutex>
#include <new>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <utility>

#include "absl/strings/str_cat.h"

namespace soilvol::depth {
namespace {

constexpr std::size_t kCachedCameras = 16;
constexpr double kRoundTripPx = 0.01;
constexpr double kMaxSlope = 1e4;

struct CameraKey {
    int width = 0;
    int height = 0;
    LensModel lens = LensModel::kPinhole;
    std::vector<double> numbers;

    bool operator==(const CameraKey& other) const {
        return width == other.width && height == other.height && lens == other.lens &&
               numbers == other.numbers;
    }
};

CameraKey KeyOf(const DepthCamera& camera, int width, int height) {
    const CameraIntrinsics& k = camera.intrinsics;
    CameraKey key{width, height, camera.lens, {k.fx, k.fy, k.cx, k.cy}};
    key.numbers.insert(key.numbers.end(), k.distortion.begin(), k.distortion.end());
    return key;
}

cv::Mat CameraMatrix(const CameraIntrinsics& k) {
    return (cv::Mat_<double>(3, 3) << k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0);
}

// Every pixel centre, row by row.
cv::Mat PixelCentres(int width, int height) {
    cv::Mat pixels(width * height, 1, CV_64FC2);
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) pixels.at<cv::Vec2d>(v * width + u) = cv::Vec2d(u, v);
    }
    return pixels;
}

// Undistorted normalised coordinates of `pixels`, and the pixels they project back to.
std::pair<cv::Mat, cv::Mat> Invert(const DepthCamera& camera, const cv::Mat& pixels) {
    const cv::Mat K = CameraMatrix(camera.intrinsics);
    const cv::Mat D(camera.intrinsics.distortion, true);
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12);
    cv::Mat normalised;
    cv::Mat back;
    if (camera.lens == LensModel::kKannalaBrandt) {
        cv::fisheye::undistortPoints(pixels, normalised, K, D, cv::noArray(), cv::noArray(),
                                     criteria);
        cv::fisheye::distortPoints(normalised, back, K, D);
    } else {
        cv::undistortPoints(pixels, normalised, K, D, cv::noArray(), cv::noArray(), criteria);
        cv::Mat points3(normalised.rows, 1, CV_64FC3);
        for (int i = 0; i < normalised.rows; ++i) {
            const cv::Vec2d p = normalised.at<cv::Vec2d>(i);
            points3.at<cv::Vec3d>(i) = cv::Vec3d(p[0], p[1], 1.0);
        }
        cv::projectPoints(points3, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, back);
    }
    return {normalised, back};
}

std::shared_ptr<const RayTable> Compute(const DepthCamera& camera, int width, int height) {
    std::vector<Eigen::Vector2f> rays(static_cast<std::size_t>(width) * height);
    const CameraIntrinsics& k = camera.intrinsics;
    if (camera.lens == LensModel::kPinhole || k.distortion.empty()) {
        for (int v = 0; v < height; ++v) {
            for (int u = 0; u < width; ++u) {
                rays[static_cast<std::size_t>(v) * width + u] = Eigen::Vector2f(
                    static_cast<float>((u - k.cx) / k.fx), static_cast<float>((v - k.cy) / k.fy));
            }
        }
        return std::make_shared<const RayTable>(width, height, std::move(rays));
    }
    const cv::Mat pixels = PixelCentres(width, height);
    const auto [normalised, back] = Invert(camera, pixels);
    const float nan = std::nanf("");
    for (int i = 0; i < pixels.rows; ++i) {
        const cv::Vec2d n = normalised.at<cv::Vec2d>(i);
        const cv::Vec2d error = back.at<cv::Vec2d>(i) - pixels.at<cv::Vec2d>(i);
        // Rays beyond kMaxSlope (89.99 deg off the axis) are no rays a depth image can use.
        const bool exact = std::abs(n[0]) <= kMaxSlope && std::abs(n[1]) <= kMaxSlope &&
                           std::hypot(error[0], error[1]) <= kRoundTripPx;
        rays[static_cast<std::size_t>(i)] =
            exact ? Eigen::Vector2f(static_cast<float>(n[0]), static_cast<float>(n[1]))
                  : Eigen::Vector2f(nan, nan);
    }
    return std::make_shared<const RayTable>(width, height, std::move(rays));
}

}  // namespace

absl::StatusOr<std::shared_ptr<const RayTable>> RaysOf(const DepthCamera& camera, int width,
                                                       int height) {
    static std::mutex mutex;
    static std::list<std::pair<CameraKey, std::shared_ptr<const RayTable>>> cache;
    CameraKey key = KeyOf(camera, width, height);
    {
        std::lock_guard<std::mutex> lock(mutex);
        for (auto it = cache.begin(); it != cache.end(); ++it) {
            if (it->first == key) {
                cache.splice(cache.begin(), cache, it);  // most recently used first
                return cache.front().second;
            }
        }
    }
    std::shared_ptr<const RayTable> table;
    try {
        table = Compute(camera, width, height);
    } catch (const cv::Exception& e) {
        return absl::InvalidArgumentError(
            absl::StrCat("camera: the lens model cannot be inverted: ", e.what()));
    } catch (const std::bad_alloc&) {
        return absl::ResourceExhaustedError("camera: out of memory computing the pixel rays");
    }
    std::lock_guard<std::mutex> lock(mutex);
    cache.emplace_front(std::move(key), table);
    if (cache.size() > kCachedCameras) cache.pop_back();
    return table;
}

}  // namespace soilvol::depth
