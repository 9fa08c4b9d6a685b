#include "core/depth/depth_scan.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <utility>
#include <vector>

#include "core/stereo/image_codec.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::depth {
namespace {

using stereo::test::IsInvalidWith;

constexpr int kWidth = 80;
constexpr int kHeight = 60;

DepthCamera Pinhole() {
    DepthCamera camera;
    camera.intrinsics = {70.0, 72.0, 39.5, 29.5, {}};
    return camera;
}

// The true point seen through pixel (u, v) of a pinhole camera: on the plane z = 2 + 0.3 x.
Eigen::Vector3d PlanePoint(const DepthCamera& camera, int u, int v) {
    const CameraIntrinsics& k = camera.intrinsics;
    const Eigen::Vector3d ray((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
    const double z = 2.0 / (1.0 - 0.3 * ray.x());
    return ray * z;
}

// The plane as a depth image: z-depth or range, in `unit` (rounded for integer images).
ScalarImage PlaneImage(const DepthCamera& camera, DepthMeaning meaning, int bits, double unit) {
    ScalarImage image{kWidth, kHeight, bits, {}};
    for (int v = 0; v < kHeight; ++v) {
        for (int u = 0; u < kWidth; ++u) {
            const Eigen::Vector3d p = PlanePoint(camera, u, v);
            const double value = (meaning == DepthMeaning::kZ ? p.z() : p.norm()) / unit;
            image.values.push_back(static_cast<float>(bits == 32 ? value : std::round(value)));
        }
    }
    return image;
}

std::string Encode(const cv::Mat& image, const std::string& extension) {
    std::vector<uchar> bytes;
    EXPECT_TRUE(cv::imencode(extension, image, bytes));
    return std::string(bytes.begin(), bytes.end());
}

cv::Mat ToMat(const ScalarImage& image, int type) {
    cv::Mat floats(image.height, image.width, CV_32F, const_cast<float*>(image.values.data()));
    cv::Mat out;
    floats.convertTo(out, type);
    return out;
}

TEST(DepthScanTest, ZDepthAndRangeImagesGiveTheSamePoints) {
    DepthCamera camera = Pinhole();
    for (DepthMeaning meaning : {DepthMeaning::kZ, DepthMeaning::kRange}) {
        camera.meaning = meaning;
        const auto cloud =
            BackProject(PlaneImage(camera, meaning, 32, 1.0), nullptr, camera, {}, "scan.depth");
        ASSERT_TRUE(cloud.ok()) << cloud.status();
        ASSERT_EQ(cloud->points.size(), static_cast<std::size_t>(kWidth * kHeight));
        EXPECT_EQ(cloud->counts.flying, 0u);
        for (std::size_t i = 0; i < cloud->points.size(); ++i) {
            const int pixel = cloud->pixel[i];
            const Eigen::Vector3d truth = PlanePoint(camera, pixel % kWidth, pixel / kWidth);
            // float storage: 1e-7 of 2-3 m, twice.
            ASSERT_LT((cloud->points[i].cast<double>() - truth).norm(), 2e-6) << pixel;
        }
    }
}

TEST(DepthScanTest, SixteenBitMillimetresAndFloatMetresDecodeAlike) {
    const DepthCamera camera = Pinhole();
    const ScalarImage mm = PlaneImage(camera, DepthMeaning::kZ, 16, 0.001);
    const ScalarImage m = PlaneImage(camera, DepthMeaning::kZ, 32, 1.0);
    const auto from_png =
        DecodeDepthScan(Encode(ToMat(mm, CV_16U), ".png"), "", camera, {}, "scan.depth");
    const auto from_tiff =
        DecodeDepthScan(Encode(ToMat(m, CV_32F), ".tiff"), "", camera, {}, "scan.depth");
    ASSERT_TRUE(from_png.ok()) << from_png.status();
    ASSERT_TRUE(from_tiff.ok()) << from_tiff.status();
    ASSERT_EQ(from_png->points.size(), from_tiff->points.size());
    for (std::size_t i = 0; i < from_png->points.size(); ++i) {
        // Millimetre rounding: 0.5 mm along z, stretched along the ray (at most 1.0005).
        ASSERT_LT((from_png->points[i] - from_tiff->points[i]).norm(), 0.0006f);
    }
    // A unit of 0.1 mm read as the default millimetres: ten times as far.
    DepthCamera tenth = camera;
    tenth.depth_unit_m = 0.0001;
    const auto scaled = BackProject(mm, nullptr, tenth, {}, "scan.depth");
    ASSERT_TRUE(scaled.ok());
    EXPECT_NEAR(scaled->points[0].z() * 10.0f, from_png->points[0].z(), 1e-4);
}

TEST(DepthScanTest, EncodedScalarImagesDecodeToTheirValues) {
    const DepthCamera camera = Pinhole();
    for (const auto& [bits, unit] : {std::pair{16, 0.001}, std::pair{32, 1.0}}) {
        const ScalarImage image = PlaneImage(camera, DepthMeaning::kZ, bits, unit);
        const auto bytes = stereo::EncodeScalar(image);
        ASSERT_TRUE(bytes.ok()) << bytes.status();
        const auto decoded = stereo::DecodeScalar(*bytes, "depth");
        ASSERT_TRUE(decoded.ok()) << decoded.status();
        EXPECT_EQ(decoded->bits, bits);
        EXPECT_EQ(decoded->values, image.values) << bits;
    }
    ScalarImage odd{2, 2, 7, {1, 2, 3, 4}};
    EXPECT_TRUE(IsInvalidWith(stereo::EncodeScalar(odd), "7 bits"));
    odd.bits = 16;
    odd.values.pop_back();
    EXPECT_TRUE(IsInvalidWith(stereo::EncodeScalar(odd), "3 values for 2x2"));
}

TEST(DepthScanTest, DroppedPixelsAreCountedByReason) {
    const DepthCamera camera = Pinhole();
    ScalarImage depth = PlaneImage(camera, DepthMeaning::kZ, 32, 1.0);
    ScalarImage confidence{kWidth, kHeight, 8, std::vector<float>(depth.values.size(), 200.0f)};
    depth.values[0] = 0.0f;
    depth.values[1] = std::nanf("");
    depth.values[2] = std::numeric_limits<float>::infinity();
    depth.values[3] = -1.0f;
    confidence.values[10] = 20.0f;
    confidence.values[11] = 49.0f;
    depth.values[20] = 150.0f;  // beyond max_range_m
    DepthScanConfig config;
    config.min_confidence = 50.0;
    config.max_range_m = 100.0;
    const auto cloud = BackProject(depth, &confidence, camera, config, "scan.depth");
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    EXPECT_EQ(cloud->counts.pixels, depth.values.size());
    EXPECT_EQ(cloud->counts.no_return, 4u);
    EXPECT_EQ(cloud->counts.low_confidence, 2u);
    EXPECT_EQ(cloud->counts.out_of_range, 1u);
    EXPECT_EQ(cloud->points.size(), depth.values.size() - 7 - cloud->counts.flying);
}

// Found by fuzz_depth_scan: a range image seen through 1-px focal lengths (rays far off the
// axis) and the smallest sub-normal depths gave NaN and zero z-depths that were neither kept
// nor counted.
TEST(DepthScanTest, EveryPixelIsKeptOrCountedOnceWhateverTheNumbers) {
    DepthCamera camera;
    camera.intrinsics = {1.0, 1.0, 0.0, 0.0, {}};
    camera.meaning = DepthMeaning::kRange;
    ScalarImage depth{kWidth, kHeight, 32, {}};
    for (int i = 0; i < kWidth * kHeight; ++i) {
        depth.values.push_back(i % 3 == 0 ? 1.4e-45f : (i % 3 == 1 ? 3e38f : 2.0f));
    }
    DepthScanConfig config;
    config.min_range_m = 0.0;
    config.max_range_m = 1e30;
    const auto cloud = BackProject(depth, nullptr, camera, config, "scan.depth");
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    const DepthScanCounts& n = cloud->counts;
    EXPECT_EQ(cloud->points.size() + n.no_return + n.low_confidence + n.out_of_range + n.no_ray +
                  n.flying,
              n.pixels);
    for (const Eigen::Vector3f& p : cloud->points) {
        ASSERT_TRUE(p.allFinite());
        ASSERT_GT(p.z(), 0.0f);
    }
}

TEST(DepthScanTest, HostileImagesAreRefusedNamingTheField) {
    const DepthCamera camera = Pinhole();
    EXPECT_TRUE(IsInvalidWith(DecodeDepthScan("", "", camera, {}, "scan.depth"),
                              "scan.depth.depth: empty"));
    EXPECT_TRUE(
        IsInvalidWith(DecodeDepthScan(std::string(500, '\x89'), "", camera, {}, "scan.depth"),
                      "scan.depth.depth: not a decodable image"));
    // 8 bits cannot hold a depth; colour is not a depth.
    const cv::Mat grey8(kHeight, kWidth, CV_8U, cv::Scalar(100));
    EXPECT_TRUE(IsInvalidWith(DecodeDepthScan(Encode(grey8, ".png"), "", camera, {}, "scan.depth"),
                              "scan.depth.depth: 8-bit samples"));
    const cv::Mat colour(kHeight, kWidth, CV_16UC3, cv::Scalar(1000, 1000, 1000));
    EXPECT_TRUE(IsInvalidWith(DecodeDepthScan(Encode(colour, ".png"), "", camera, {}, "scan.depth"),
                              "scan.depth.depth: 3 channels"));
    // A header declaring more than the budget is refused before anything is decoded.
    std::string huge = Encode(cv::Mat(8, 8, CV_16U, cv::Scalar(1000)), ".png");
    huge[16] = '\x00';
    huge[17] = '\x01';  // width 65536 + 8
    EXPECT_TRUE(IsInvalidWith(DecodeDepthScan(huge, "", camera, {}, "scan.depth"),
                              "is larger than 8192 px"));
    // A confidence image of another size.
    const std::string depth = Encode(cv::Mat(kHeight, kWidth, CV_16U, cv::Scalar(2000)), ".png");
    const std::string small = Encode(cv::Mat(10, 10, CV_8U, cv::Scalar(255)), ".png");
    EXPECT_TRUE(IsInvalidWith(DecodeDepthScan(depth, small, camera, {}, "scan.depth"),
                              "scan.depth.confidence: 10x10 does not match"));
}

TEST(DepthScanTest, CamerasThatCannotDescribeTheImageAreRefused) {
    const ScalarImage depth = PlaneImage(Pinhole(), DepthMeaning::kZ, 16, 0.001);
    DepthCamera camera = Pinhole();
    camera.intrinsics.fx = 0.0;
    EXPECT_TRUE(IsInvalidWith(BackProject(depth, nullptr, camera, {}, "scan.depth"),
                              "scan.depth.camera.fx/fy"));
    camera = Pinhole();
    camera.intrinsics.cy = std::nan("");
    EXPECT_TRUE(IsInvalidWith(BackProject(depth, nullptr, camera, {}, "scan.depth"),
                              "scan.depth.camera.cx/cy"));
    camera = Pinhole();
    camera.lens = LensModel::kKannalaBrandt;
    camera.intrinsics.distortion = {0.1, 0.01, 0.0};
    EXPECT_TRUE(IsInvalidWith(BackProject(depth, nullptr, camera, {}, "scan.depth"),
                              "scan.depth.camera.distortion: 3 coefficients"));
    camera = Pinhole();
    camera.depth_unit_m = -0.001;
    EXPECT_TRUE(IsInvalidWith(BackProject(depth, nullptr, camera, {}, "scan.depth"),
                              "scan.depth.camera.depth_unit_m"));
}

}  // namespace
}  // namespace soilvol::depth
