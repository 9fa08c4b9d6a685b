#include "core/stereo/chessboard_detector.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "core/stereo/opencv_image.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo::detail {
namespace {

const cv::Size kPattern(9, 6);

cv::Mat SampleImage(const std::string& name) {
    const std::string bytes = test::ReadFile(test::kSampleDir + name);
    if (bytes.empty()) return {};
    absl::StatusOr<cv::Mat> image = DecodeGreyMat(bytes, name);
    return image.ok() ? *image : cv::Mat();
}

TEST(DetectChessboardTest, LargeImagesAreDetectedOnACopyAndRefinedAtFullSize) {
    const cv::Mat image = SampleImage("left01.jpg");
    SOILVOL_NEED_SAMPLES(image.empty(), "opencv-doc sample images");
    const auto corners = DetectChessboard(image, kPattern);
    ASSERT_TRUE(corners.has_value());
    ASSERT_EQ(corners->size(), 54u);

    constexpr double kScale = 2.5;  // 1600 x 1200: detected at 1280 x 960
    cv::Mat large;
    cv::resize(image, large, cv::Size(), kScale, kScale, cv::INTER_CUBIC);
    const auto large_corners = DetectChessboard(large, kPattern);
    ASSERT_TRUE(large_corners.has_value());
    for (std::size_t i = 0; i < corners->size(); ++i) {
        const cv::Point2f expected =
            ((*corners)[i] + cv::Point2f(0.5f, 0.5f)) * static_cast<float>(kScale) -
            cv::Point2f(0.5f, 0.5f);
        EXPECT_LT(cv::norm((*large_corners)[i] - expected), 0.25 * kScale) << i;
    }
}

TEST(DetectChessboardTest, BoardFreeImagesAreRejectedQuickly) {
    const cv::Mat image = SampleImage("baboon.jpg");
    SOILVOL_NEED_SAMPLES(image.empty(), "opencv-doc sample images");
    const auto start = std::chrono::steady_clock::now();
    EXPECT_FALSE(DetectChessboard(image, kPattern).has_value());
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 0.5);
}

}  // namespace
}  // namespace soilvol::stereo::detail
