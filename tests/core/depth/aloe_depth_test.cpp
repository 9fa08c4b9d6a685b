// Real data nobody here made: the Middlebury "Aloe" ground-truth disparity shipped in Debian's
// opencv-doc, taken as the disparity of a rectified rig, turned into the depth image that rig's
// left camera would give (z = f b / d), back-projects to the points the stereo path's Q
// reprojection gives for that disparity; and the flying-pixel filter keeps its returns, which
// have edges everywhere (leaves) and no mixed pixels (structured light, no ToF mixing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "core/depth/depth_scan.hpp"
#include "core/stereo/calibration.hpp"
#include "core/stereo/image_codec.hpp"
#include "core/stereo/reconstructor.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::depth {
namespace {

using stereo::test::kSampleDir;
using stereo::test::ReadFile;

struct Aloe {
    ScalarImage disparity;
    stereo::StereoCalibration calibration;
};

// Middlebury 2006's rig scaled to the image: 3740 px focal length at 1282 px wide, 160 mm apart.
Aloe LoadAloe(const std::string& gt) {
    Aloe aloe;
    auto disparity = stereo::DecodeScalar(gt, "aloeGT.png");
    EXPECT_TRUE(disparity.ok()) << disparity.status();
    aloe.disparity = *disparity;
    StereoParameters rig;
    rig.image_width = aloe.disparity.width;
    rig.image_height = aloe.disparity.height;
    const double f = 3740.0 * aloe.disparity.width / 1282.0;
    rig.left = {f, f, (aloe.disparity.width - 1) / 2.0, (aloe.disparity.height - 1) / 2.0, {}};
    rig.right = rig.left;
    rig.t_right_left_m = Eigen::Vector3d(-0.160, 0.0, 0.0);
    auto calibration = stereo::CalibrationFromParameters(rig);
    EXPECT_TRUE(calibration.ok()) << calibration.status();
    aloe.calibration = *calibration;
    return aloe;
}

// The depth image the rectified left camera gives: z = f b / d as 32-bit float TIFF [m].
std::string DepthTiff(const Aloe& aloe) {
    cv::Mat z(aloe.disparity.height, aloe.disparity.width, CV_32F, cv::Scalar(0.0));
    for (int v = 0; v < z.rows; ++v) {
        for (int u = 0; u < z.cols; ++u) {
            const float d = aloe.disparity.At(u, v);
            if (d > 0.0f) {
                z.at<float>(v, u) =
                    static_cast<float>(aloe.calibration.focal_px * aloe.calibration.baseline_m /
                                       static_cast<double>(d));
            }
        }
    }
    std::vector<uchar> bytes;
    EXPECT_TRUE(cv::imencode(".tiff", z, bytes));
    return std::string(bytes.begin(), bytes.end());
}

DepthCamera RectifiedLeft(const stereo::StereoCalibration& calibration) {
    DepthCamera camera;
    const auto& P = calibration.P1;
    camera.intrinsics = {P(0, 0), P(1, 1), P(0, 2), P(1, 2), {}};
    return camera;
}

TEST(AloeDepthTest, DepthImageBackProjectsToTheStereoReprojection) {
    const std::string gt = ReadFile(kSampleDir + "aloeGT.png");
    SOILVOL_NEED_SAMPLES(gt.empty(), "opencv-doc's aloeGT.png");
    const Aloe aloe = LoadAloe(gt);
    const auto stereo = stereo::StereoReconstructor::Create(aloe.calibration);
    ASSERT_TRUE(stereo.ok()) << stereo.status();
    DepthScanConfig config;
    config.flying.enabled = false;
    config.max_range_m = 1e6;
    const auto cloud =
        DecodeDepthScan(DepthTiff(aloe), "", RectifiedLeft(aloe.calibration), config, "scan.depth");
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    std::size_t known = 0;
    for (float d : aloe.disparity.values) known += d > 0.0f;
    ASSERT_GT(known, aloe.disparity.values.size() / 2);
    ASSERT_EQ(cloud->points.size(), known);
    double worst = 0.0;
    for (std::size_t i = 0; i < cloud->points.size(); ++i) {
        const int u = cloud->pixel[i] % aloe.disparity.width;
        const int v = cloud->pixel[i] / aloe.disparity.width;
        const Eigen::Vector3d reprojected =
            stereo->Reproject(u, v, static_cast<double>(aloe.disparity.At(u, v)));
        worst = std::max(
            worst, (cloud->points[i].cast<double>() - reprojected).norm() / reprojected.norm());
    }
    // Both carry the depth in float once (the TIFF) : a few parts in 1e7.
    EXPECT_LT(worst, 1e-6);
}

TEST(AloeDepthTest, FlyingPixelFilterKeepsTheRealSurfaces) {
    const std::string gt = ReadFile(kSampleDir + "aloeGT.png");
    SOILVOL_NEED_SAMPLES(gt.empty(), "opencv-doc's aloeGT.png");
    const Aloe aloe = LoadAloe(gt);
    DepthScanConfig config;
    config.max_range_m = 1e6;
    // The ground truth's own resolution, one disparity step: z^2 / (f b) at depth z, so at the
    // far end (the smallest disparity d) z / (f b) = 1 / d per metre of depth.
    float min_disparity = std::numeric_limits<float>::max();
    for (const float d : aloe.disparity.values) {
        if (d > 0.0f) min_disparity = std::min(min_disparity, d);
    }
    config.flying.noise_at_1m_m = 1.0 / static_cast<double>(min_disparity);
    const auto cloud =
        DecodeDepthScan(DepthTiff(aloe), "", RectifiedLeft(aloe.calibration), config, "scan.depth");
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    const double kept = static_cast<double>(cloud->points.size()) /
                        static_cast<double>(cloud->points.size() + cloud->counts.flying);
    EXPECT_GE(kept, 0.99) << cloud->counts.flying << " flagged";
}

}  // namespace
}  // namespace soilvol::depth
