#include "core/depth/ray_table.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>

namespace soilvol::depth {
namespace {

constexpr int kTableWidth = 160;
constexpr int kTableHeight = 120;

// The lens models written out (OpenCV's documentation of calib3d and of cv::fisheye), as an
// independent forward model: normalised undistorted (x, y) -> pixel.
Eigen::Vector2d Distort(const DepthCamera& camera, const Eigen::Vector2f& ray) {
    const CameraIntrinsics& k = camera.intrinsics;
    const double x = static_cast<double>(ray.x());
    const double y = static_cast<double>(ray.y());
    double xd = x;
    double yd = y;
    const std::vector<double>& c = k.distortion;
    if (camera.lens == LensModel::kBrownConrady) {
        const double r2 = x * x + y * y;
        const double k3 = c.size() > 4 ? c[4] : 0.0;
        double radial = 1.0 + c[0] * r2 + c[1] * r2 * r2 + k3 * r2 * r2 * r2;
        if (c.size() == 8) radial /= 1.0 + c[5] * r2 + c[6] * r2 * r2 + c[7] * r2 * r2 * r2;
        xd = x * radial + 2.0 * c[2] * x * y + c[3] * (r2 + 2.0 * x * x);
        yd = y * radial + c[2] * (r2 + 2.0 * y * y) + 2.0 * c[3] * x * y;
    } else if (camera.lens == LensModel::kKannalaBrandt) {
        const double r = std::hypot(x, y);
        const double theta = std::atan(r);
        const double t2 = theta * theta;
        const double theta_d = theta * (1.0 + c[0] * t2 + c[1] * t2 * t2 + c[2] * t2 * t2 * t2 +
                                        c[3] * t2 * t2 * t2 * t2);
        const double scale = r > 1e-12 ? theta_d / r : 1.0;
        xd = x * scale;
        yd = y * scale;
    }
    return {k.fx * xd + k.cx, k.fy * yd + k.cy};
}

void ExpectRaysReproduceTheirPixels(const DepthCamera& camera, double min_share_valid) {
    const auto table = RaysOf(camera, kTableWidth, kTableHeight);
    ASSERT_TRUE(table.ok()) << table.status();
    std::size_t valid = 0;
    for (int v = 0; v < kTableHeight; ++v) {
        for (int u = 0; u < kTableWidth; ++u) {
            const Eigen::Vector2f& ray = (*table)->At(v * kTableWidth + u);
            if (!std::isfinite(ray.x())) continue;
            ++valid;
            // float storage of x, y: ~1e-7 of a ray, 1e-5 px at these focal lengths.
            ASSERT_LT((Distort(camera, ray) - Eigen::Vector2d(u, v)).norm(), 0.011)
                << u << "," << v;
        }
    }
    EXPECT_GE(static_cast<double>(valid), min_share_valid * kTableWidth * kTableHeight);
}

TEST(RayTableTest, PinholeRaysAreThePixelsOverTheFocalLength) {
    DepthCamera camera;
    camera.intrinsics = {150.0, 148.0, 80.2, 59.7, {}};
    ExpectRaysReproduceTheirPixels(camera, 1.0);
    const auto table = RaysOf(camera, kTableWidth, kTableHeight);
    ASSERT_TRUE(table.ok());
    EXPECT_FLOAT_EQ((*table)->At(0).x(), static_cast<float>(-80.2 / 150.0));
    EXPECT_FLOAT_EQ((*table)->At(0).y(), static_cast<float>(-59.7 / 148.0));
}

TEST(RayTableTest, BrownConradyRaysProjectBackToTheirPixels) {
    DepthCamera camera;
    camera.lens = LensModel::kBrownConrady;
    // A ToF camera's wide lens (barrel), with tangential terms; and the rational model.
    camera.intrinsics = {120.0, 121.0, 79.0, 61.0, {-0.28, 0.09, 0.001, -0.0007, -0.012}};
    ExpectRaysReproduceTheirPixels(camera, 1.0);
    camera.intrinsics.distortion = {0.5, -0.1, 0.001, 0.002, 0.01, 0.8, -0.05, 0.02};
    ExpectRaysReproduceTheirPixels(camera, 0.99);
}

TEST(RayTableTest, FisheyeRaysProjectBackOrAreLeftOut) {
    DepthCamera camera;
    camera.lens = LensModel::kKannalaBrandt;
    camera.intrinsics = {60.0, 60.0, 80.0, 60.0, {0.05, -0.01, 0.002, -0.0003}};
    ExpectRaysReproduceTheirPixels(camera, 0.99);
}

TEST(RayTableTest, OneTablePerCameraIsKept) {
    DepthCamera camera;
    camera.intrinsics = {150.0, 150.0, 80.0, 60.0, {}};
    const auto first = RaysOf(camera, kTableWidth, kTableHeight);
    const auto again = RaysOf(camera, kTableWidth, kTableHeight);
    ASSERT_TRUE(first.ok() && again.ok());
    EXPECT_EQ(first->get(), again->get());
    camera.intrinsics.fx = 151.0;
    const auto other = RaysOf(camera, kTableWidth, kTableHeight);
    ASSERT_TRUE(other.ok());
    EXPECT_NE(first->get(), other->get());
    EXPECT_EQ((*RaysOf(camera, kTableWidth, kTableHeight - 1))->height(), kTableHeight - 1);
}

}  // namespace
}  // namespace soilvol::depth
