#include "core/stereo/pixel_corners.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "core/common/polygon.hpp"
#include "core/sim/stereo_renderer.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo {
namespace {

using test::HasError;

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
constexpr double kSubpixel = 1.0 / 16.0;  // SGBM's disparity step [px]

// A 1.2 m x 0.8 m rim 3 m in front of the simulated rig (640x480, 10 cm baseline, f = 554 px),
// tilted 40 deg towards the camera, as a container's opening seen from above and in front.
struct Rim {
    Corners left;  // corners in the left camera frame [m]
    Eigen::Vector3d normal_left;
};

Rim TrueRim() {
    const Eigen::Matrix3d tilt = Eigen::AngleAxisd(-0.7, Eigen::Vector3d::UnitX()).matrix();
    const Eigen::Vector3d centre(0.05, 0.1, 3.0);
    Rim rim;
    const std::array<Eigen::Vector2d, 4> local = {
        Eigen::Vector2d(-0.6, -0.4), Eigen::Vector2d(0.6, -0.4), Eigen::Vector2d(0.6, 0.4),
        Eigen::Vector2d(-0.6, 0.4)};
    for (int i = 0; i < 4; ++i) {
        rim.left[i] = centre + tilt * Eigen::Vector3d(local[i].x(), local[i].y(), 0.0);
    }
    rim.normal_left = tilt * Eigen::Vector3d::UnitZ();
    return rim;
}

class PixelCornersTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        auto calibration = CalibrationFromParameters(sim::RigParameters(rig_));
        ASSERT_TRUE(calibration.ok()) << calibration.status();
        auto reconstructor = StereoReconstructor::Create(*calibration);
        ASSERT_TRUE(reconstructor.ok()) << reconstructor.status();
        reconstructor_ = new StereoReconstructor(*std::move(reconstructor));
    }
    static void TearDownTestSuite() { delete reconstructor_; }

    static const StereoCalibration& Calibration() { return reconstructor_->calibration(); }

    // Disparity [px] the rim's plane has at rectified pixel (u, v): X = Z r with
    // r = ((u - cx) / f, (v - cy) / f, 1) on n.X = k gives d = f B / Z = f B (n.r) / k.
    static double PlaneDisparity(const Rim& rim, double u, double v) {
        const StereoCalibration& c = Calibration();
        const Eigen::Vector3d n = c.R1 * rim.normal_left;
        const double k = n.dot(c.R1 * rim.left[0]);
        const double f = c.P1(0, 0);
        const Eigen::Vector3d r((u - c.P1(0, 2)) / f, (v - c.P1(1, 2)) / f, 1.0);
        return f * c.baseline_m * n.dot(r) / k;
    }

    static PixelCorners RawPixels(const Rim& rim) {
        PixelCorners px;
        for (int i = 0; i < 4; ++i) px[i] = sim::ProjectLeft(rig_, rim.left[i]);
        return px;
    }

    // What SGBM would give for the rim: within 3 px of the rectified quadrilateral's edges the
    // rim plane's disparity in steps of 1/16 px; inside, the container's floor 25% farther;
    // outside, nothing (sky).
    static DisparityMap RimDisparity(const Rim& rim) {
        std::vector<Eigen::Vector2d> quad;
        for (const Eigen::Vector2d& px : RawPixels(rim)) {
            quad.push_back(reconstructor_->RectifyLeftPixel(px));
        }
        const Polygon2d polygon(quad);
        DisparityMap map;
        map.width = rig_.image_width;
        map.height = rig_.image_height;
        map.values.assign(static_cast<std::size_t>(map.width * map.height), kNaNf);
        for (int v = 0; v < map.height; ++v) {
            for (int u = 0; u < map.width; ++u) {
                const Eigen::Vector2d p(u, v);
                const bool rim_band = polygon.DistanceToBoundary(p) <= 3.0;
                if (!rim_band && !polygon.Contains(p)) continue;
                const double d = PlaneDisparity(rim, u, v) * (rim_band ? 1.0 : 0.8);
                map.values[static_cast<std::size_t>(v * map.width + u)] =
                    static_cast<float>(std::round(d / kSubpixel) * kSubpixel);
                ++map.valid;
            }
        }
        return map;
    }

    static inline const sim::StereoRigSpec rig_{};
    static StereoReconstructor* reconstructor_;
};

StereoReconstructor* PixelCornersTest::reconstructor_ = nullptr;

// The corners' true pixels lifted through a disparity map of the rim land on the true corners
// (rectified left frame) within the depth step of 1/16 px there, Z^2 / (f B) / 16 (1 cm at 3 m):
// the plane fit averages thousands of quantised disparities, so it does better than one.
TEST_F(PixelCornersTest, CornersLiftToTheTrueCornersWithinTheDepthResolution) {
    const Rim rim = TrueRim();
    const auto lifted = LiftPixelCorners(*reconstructor_, RimDisparity(rim), RawPixels(rim));
    ASSERT_TRUE(lifted.ok()) << lifted.status();
    const StereoCalibration& c = Calibration();
    for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d truth = c.R1 * rim.left[i];
        const double depth_step = truth.z() * truth.z() / (c.focal_px * c.baseline_m) * kSubpixel;
        EXPECT_LT((lifted->corners[i] - truth).norm(), depth_step) << "corner " << i;
        // The rectified pixel is the true point's projection (undistortPoints' 5 iterations
        // leave < 0.01 px at this lens's -0.08 k1).
        EXPECT_LT((lifted->rectified_px[i] - reconstructor_->ProjectRectified(truth)).norm(), 0.01)
            << "corner " << i;
    }
    // Inliers are the rim's 6 px of the 10 px band; their residuals are the rounding to 1/16 px,
    // uniform: RMS 1/16/sqrt(12) = 0.018 px.
    EXPECT_GT(lifted->inliers, lifted->band_pixels / 2);
    EXPECT_LT(lifted->inliers, lifted->band_pixels);
    EXPECT_NEAR(lifted->rms_px, kSubpixel / std::sqrt(12.0), 0.005);
}

TEST_F(PixelCornersTest, CornersOffTheImageOrNotFiniteAreInvalidArgumentNamingTheCorner) {
    const Rim rim = TrueRim();
    const DisparityMap disparity = RimDisparity(rim);
    const double inf = std::numeric_limits<double>::infinity();
    const std::vector<std::pair<Eigen::Vector2d, int>> bad = {
        {Eigen::Vector2d(700.0, 10.0), 2},  {Eigen::Vector2d(-1.0, 200.0), 0},
        {Eigen::Vector2d(320.0, 480.0), 3}, {Eigen::Vector2d(std::nan(""), 200.0), 1},
        {Eigen::Vector2d(320.0, inf), 2},
    };
    for (const auto& [pixel, corner] : bad) {
        PixelCorners corners = RawPixels(rim);
        corners[corner] = pixel;
        const auto lifted = LiftPixelCorners(*reconstructor_, disparity, corners);
        EXPECT_TRUE(HasError(lifted.status(), absl::StatusCode::kInvalidArgument,
                             absl::StrCat("pixel corner ", corner)));
    }
}

TEST_F(PixelCornersTest, CrossedOrCollapsedQuadrilateralsAreInvalidArgument) {
    const Rim rim = TrueRim();
    const DisparityMap disparity = RimDisparity(rim);
    PixelCorners crossed = RawPixels(rim);
    std::swap(crossed[1], crossed[2]);
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, disparity, crossed).status(),
                         absl::StatusCode::kInvalidArgument, "edges cross"));
    PixelCorners collapsed = RawPixels(rim);
    collapsed[3] = collapsed[2] + Eigen::Vector2d(3.0, 2.0);  // 3.6 px, under the 8 px edge
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, disparity, collapsed).status(),
                         absl::StatusCode::kInvalidArgument, "pixel corners 2 and 3"));
    PixelCorners point = RawPixels(rim);
    point.fill(point[0]);
    EXPECT_EQ(LiftPixelCorners(*reconstructor_, disparity, point).status().code(),
              absl::StatusCode::kInvalidArgument);
}

TEST_F(PixelCornersTest, ADisparityMapOfAnotherSizeIsInvalidArgument) {
    const Rim rim = TrueRim();
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, DisparityMap{}, RawPixels(rim)).status(),
                         absl::StatusCode::kInvalidArgument, "does not match"));
}

TEST_F(PixelCornersTest, RimsWithoutAPlaneAreFailedPrecondition) {
    const Rim rim = TrueRim();
    const PixelCorners corners = RawPixels(rim);
    DisparityMap empty = RimDisparity(rim);
    std::fill(empty.values.begin(), empty.values.end(), kNaNf);
    empty.valid = 0;
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, empty, corners).status(),
                         absl::StatusCode::kFailedPrecondition, "only 0 valid disparities"));

    // Matching noise: disparities uniform over 79 px agree with any one plane within 0.5 px at
    // a rate of 1/79; the band of a 20-px quadrilateral holds ~900, so a plane gathers 11 +- 3.3
    // of them and the best of 400 tries about 21, under the 40 inliers needed.
    DisparityMap noise = empty;
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<float> any(1.0f, 80.0f);
    for (float& d : noise.values) d = any(rng);
    noise.valid = noise.values.size();
    const PixelCorners small = {Eigen::Vector2d(300, 200), Eigen::Vector2d(320, 200),
                                Eigen::Vector2d(320, 220), Eigen::Vector2d(300, 220)};
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, noise, small).status(),
                         absl::StatusCode::kFailedPrecondition, "no rim plane fits"));
}

// A plane whose disparity falls to 0 before one corner (the rim seen edge-on towards the
// horizon) puts that corner at infinity.
TEST_F(PixelCornersTest, ACornerBeyondTheHorizonIsFailedPrecondition) {
    DisparityMap ramp;
    ramp.width = rig_.image_width;
    ramp.height = rig_.image_height;
    ramp.values.resize(static_cast<std::size_t>(ramp.width * ramp.height));
    for (int v = 0; v < ramp.height; ++v) {
        for (int u = 0; u < ramp.width; ++u) {
            const float d = 0.1f * static_cast<float>(u - 200);
            ramp.values[static_cast<std::size_t>(v * ramp.width + u)] = d > 0.0f ? d : kNaNf;
        }
    }
    const PixelCorners corners = {Eigen::Vector2d(150, 150), Eigen::Vector2d(500, 150),
                                  Eigen::Vector2d(500, 350), Eigen::Vector2d(150, 350)};
    EXPECT_TRUE(HasError(LiftPixelCorners(*reconstructor_, ramp, corners).status(),
                         absl::StatusCode::kFailedPrecondition, "at infinity"));
}

}  // namespace
}  // namespace soilvol::stereo
