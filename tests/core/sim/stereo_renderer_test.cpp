#include "core/sim/stereo_renderer.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "core/common/angles.hpp"
#include "core/common/timer.hpp"
#include "core/sim/pinhole_camera.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"

namespace soilvol::sim {
namespace {

StereoRigSpec Rig(int width, int height) {
    StereoRigSpec rig;
    rig.image_width = width;
    rig.image_height = height;
    return rig;
}

SceneSpec HalfFullPaperBucket() {
    SceneSpec spec;
    spec.container = ContainerKind::kPaperBucket;
    spec.sensor = ViewpointFor(spec.container);
    spec.soil.fill_height_m = 0.3;
    return spec;
}

constexpr int kWidth = 480;
constexpr int kHeight = 360;

// The paper bucket half full, rendered once for several tests.
const StereoScene& PaperBucketScene() {
    static const StereoScene scene = [] {
        Timer timer;
        StereoScene rendered = RenderStereoScene(HalfFullPaperBucket(), Rig(kWidth, kHeight));
        std::printf("container=paper_bucket width=%d height=%d supersampling=2 render_ms=%.0f\n",
                    kWidth, kHeight, timer.Lap());
        return rendered;
    }();
    return scene;
}

// Exact first hits of pixel rays in the rendered scene (container frame inside, left frame out).
class SceneTruth {
  public:
    SceneTruth(const SceneSpec& spec, const Pose& T_left_container)
        : container_(MakeContainer(spec.container)),
          raycaster_(container_, SoilSurface(container_, spec.soil, spec.soil_seed)),
          T_left_container_(T_left_container),
          T_container_left_(T_left_container.inverse()) {}

    std::optional<RayHit> Hit(const PinholeCamera& camera, const Eigen::Vector2d& pixel) const {
        return raycaster_.CastHit(T_container_left_ * camera.Centre(),
                                  T_container_left_.linear() * camera.Direction(pixel), 50.0);
    }
    std::optional<Eigen::Vector3d> Point(const PinholeCamera& camera,
                                         const Eigen::Vector2d& pixel) const {
        const std::optional<RayHit> hit = Hit(camera, pixel);
        if (!hit) return std::nullopt;
        return camera.Centre() + hit->distance * camera.Direction(pixel);
    }
    // Material seen at the centre and the four corners of a pixel, or nullopt if they differ.
    std::optional<int> UniformMaterial(const PinholeCamera& camera, int u, int v) const {
        std::optional<int> material;
        for (const Eigen::Vector2d& offset :
             {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(0.5, -0.5),
              Eigen::Vector2d(-0.5, 0.5), Eigen::Vector2d(0.5, 0.5)}) {
            const std::optional<RayHit> hit = Hit(camera, Eigen::Vector2d(u, v) + offset);
            const int m = hit ? static_cast<int>(hit->material) : -1;
            if (material && *material != m) return std::nullopt;
            material = m;
        }
        return material;
    }

  private:
    ContainerGeometry container_;
    SceneRaycaster raycaster_;
    Pose T_left_container_;
    Pose T_container_left_;
};

double Bilinear(const GreyImage& image, const Eigen::Vector2d& px) {
    const int u = static_cast<int>(std::floor(px.x()));
    const int v = static_cast<int>(std::floor(px.y()));
    const double fu = px.x() - u;
    const double fv = px.y() - v;
    return (1 - fv) * ((1 - fu) * image.At(u, v) + fu * image.At(u + 1, v)) +
           fv * ((1 - fu) * image.At(u, v + 1) + fu * image.At(u + 1, v + 1));
}

bool Inside(const Eigen::Vector2d& px, int width, int height, double margin) {
    return px.allFinite() && px.x() >= margin && px.y() >= margin && px.x() <= width - 1 - margin &&
           px.y() <= height - 1 - margin;
}

struct Moments {
    double n = 0.0, sum = 0.0, sum_sq = 0.0;
    void Add(double x) {
        n += 1.0;
        sum += x;
        sum_sq += x * x;
    }
    double Mean() const { return sum / n; }
    double Sigma() const { return std::sqrt(std::max(0.0, sum_sq / n - Mean() * Mean())); }
};

TEST(StereoRendererTest, OpticalAxisProjectsToThePrincipalPoint) {
    const StereoRigSpec rig = Rig(640, 480);
    const Eigen::Vector2d px = ProjectLeft(rig, Eigen::Vector3d(0.0, 0.0, 2.0));
    EXPECT_NEAR(px.x(), 319.5, 1e-12);
    EXPECT_NEAR(px.y(), 239.5, 1e-12);
    EXPECT_TRUE(ProjectLeft(rig, Eigen::Vector3d(0.1, 0.0, -1.0)).hasNaN());  // behind
}

TEST(StereoRendererTest, ProjectionFollowsOpenCvsDistortionModel) {
    StereoRigSpec rig = Rig(640, 480);
    rig.distortion = {-0.1, 0.03, 0.001, -0.002, 0.01};
    const double x = 0.3, y = -0.2, r2 = x * x + y * y;
    const double radial = 1.0 - 0.1 * r2 + 0.03 * r2 * r2 + 0.01 * r2 * r2 * r2;
    const double xd = x * radial + 2.0 * 0.001 * x * y - 0.002 * (r2 + 2.0 * x * x);
    const double yd = y * radial + 0.001 * (r2 + 2.0 * y * y) + 2.0 * -0.002 * x * y;
    const double f = 320.0 / std::tan(kPi / 6.0);
    const Eigen::Vector2d px = ProjectLeft(rig, Eigen::Vector3d(x, y, 1.0) * 2.5);
    EXPECT_NEAR(px.x(), f * xd + 319.5, 1e-9);
    EXPECT_NEAR(px.y(), f * yd + 239.5, 1e-9);
}

TEST(StereoRendererTest, PixelRaysProjectBackToTheirPixelsOverTheWholeImage) {
    const StereoRigSpec rig = Rig(640, 480);
    const std::array<PinholeCamera, 2> cameras = RigCameras(rig);
    double worst_left = 0.0, worst_right = 0.0;
    for (double v = -0.5; v <= 479.5; v += 7.9) {
        for (double u = -0.5; u <= 639.5; u += 7.9) {
            const Eigen::Vector2d pixel(u, v);
            const Eigen::Vector3d on_left = 3.0 * cameras[0].Direction(pixel);
            const Eigen::Vector3d on_right =
                cameras[1].Centre() + 2.0 * cameras[1].Direction(pixel);
            worst_left = std::max(worst_left, (ProjectLeft(rig, on_left) - pixel).norm());
            worst_right = std::max(worst_right, (ProjectRight(rig, on_right) - pixel).norm());
        }
    }
    EXPECT_LT(worst_left, 1e-6);
    EXPECT_LT(worst_right, 1e-6);
}

TEST(StereoRendererTest, RigParametersPlaceTheRightCameraAtTheBaseline) {
    StereoRigSpec rig = Rig(640, 480);
    rig.baseline_m = 0.12;
    const StereoParameters p = RigParameters(rig);
    const double f = 320.0 / std::tan(kPi / 6.0);
    EXPECT_NEAR(p.left.fx, f, 1e-9);
    EXPECT_NEAR(p.left.fy, f, 1e-9);
    EXPECT_EQ(p.left.cx, 319.5);
    EXPECT_EQ(p.left.cy, 239.5);
    EXPECT_EQ(p.right.distortion, rig.distortion);
    EXPECT_EQ(p.image_width, 640);
    EXPECT_NEAR((p.R_right_left * p.R_right_left.transpose() - Eigen::Matrix3d::Identity()).norm(),
                0.0, 1e-12);
    EXPECT_NEAR(p.R_right_left.determinant(), 1.0, 1e-12);
    const Eigen::AngleAxisd angle_axis(p.R_right_left);
    EXPECT_NEAR(angle_axis.angle(), rig.right_rotation_deg.norm() * kPi / 180.0, 1e-12);
    const Eigen::Vector3d right_centre = -p.R_right_left.transpose() * p.t_right_left_m;
    EXPECT_NEAR((right_centre - Eigen::Vector3d(0.12, 0.0, 0.0)).norm(), 0.0, 1e-12);
    // ProjectRight is the right camera of these parameters.
    const Eigen::Vector3d X(0.2, -0.1, 1.7);
    PinholeCamera right(p.right);
    EXPECT_NEAR(
        (ProjectRight(rig, X) - right.Project(p.R_right_left * X + p.t_right_left_m)).norm(), 0.0,
        1e-9);
}

TEST(StereoRendererTest, IdealRigDisparityIsFocalTimesBaselineOverDepth) {
    StereoRigSpec rig = Rig(640, 480);
    rig.distortion.clear();
    rig.right_rotation_deg.setZero();
    const double f = RigParameters(rig).left.fx;
    for (const Eigen::Vector3d& X :
         {Eigen::Vector3d(0.3, -0.2, 2.0), Eigen::Vector3d(-1.0, 0.4, 4.5)}) {
        const Eigen::Vector2d left = ProjectLeft(rig, X);
        const Eigen::Vector2d right = ProjectRight(rig, X);
        EXPECT_NEAR(left.x() - right.x(), f * rig.baseline_m / X.z(), 1e-9);
        EXPECT_NEAR(left.y(), right.y(), 1e-9);
    }
}

TEST(StereoRendererTest, GroundTruthMatchesTheSimulatedScan) {
    SceneSpec spec = HalfFullPaperBucket();
    spec.jitter = {5.0, 0.1};
    spec.scan_seed = 9;
    spec.sensor.angular_resolution_deg = 2.0;
    const StereoScene stereo = RenderStereoScene(spec, Rig(32, 24));
    const Scene scan = SimulateScene(spec);
    EXPECT_TRUE(stereo.T_left_container.isApprox(scan.T_scan_container, 0.0));
    EXPECT_EQ(stereo.true_volume_m3, scan.true_volume_m3);
    EXPECT_NEAR(stereo.true_volume_m3, 2.05 * 0.54 * 0.3, 0.01);
    EXPECT_EQ(stereo.struck_capacity_m3, scan.struck_capacity_m3);
    EXPECT_EQ(stereo.heaped_capacity_sae_m3, scan.heaped_capacity_sae_m3);
    const StereoScene no_images = RenderStereoScene(spec, Rig(0, 0));  // same truth
    EXPECT_TRUE(no_images.left.pixels.empty());
    for (int i = 0; i < 4; ++i) {
        EXPECT_TRUE(stereo.opening_corners_left[i].isApprox(scan.opening_corners_scan[i], 1e-12));
        EXPECT_EQ(no_images.opening_corners_left[i], stereo.opening_corners_left[i]);
    }
}

TEST(StereoRendererTest, OpeningCornerPixelsAreTheirProjections) {
    const StereoScene& scene = PaperBucketScene();
    const StereoRigSpec rig = Rig(kWidth, kHeight);
    const ContainerGeometry bucket = MakeContainer(ContainerKind::kPaperBucket);
    for (int i = 0; i < 4; ++i) {
        EXPECT_TRUE(scene.opening_corners_left[i].isApprox(
            scene.T_left_container * bucket.opening_corners[i], 1e-12));
        EXPECT_EQ(scene.opening_corners_px[i], ProjectLeft(rig, scene.opening_corners_left[i]));
        EXPECT_TRUE(Inside(scene.opening_corners_px[i], kWidth, kHeight, 0.0))
            << scene.opening_corners_px[i].transpose();
    }
}

TEST(StereoRendererTest, LeftAndRightImagesShowTheSamePoints) {
    // A true point seen at a left pixel projects into the right image where the right camera
    // sees the same point (unless occluded) and the same grey level (Lambertian, world texture).
    const StereoScene& scene = PaperBucketScene();
    const StereoRigSpec rig = Rig(kWidth, kHeight);
    const SceneTruth truth(HalfFullPaperBucket(), scene.T_left_container);
    const std::array<PinholeCamera, 2> cameras = RigCameras(rig);
    int points = 0, same_point = 0;
    std::vector<double> matched, shifted;
    for (int v = 0; v < kHeight; v += 4) {
        for (int u = 0; u < kWidth; u += 4) {
            const std::optional<Eigen::Vector3d> X = truth.Point(cameras[0], Eigen::Vector2d(u, v));
            if (!X) continue;
            const Eigen::Vector2d right_px = ProjectRight(rig, *X);
            if (!Inside(right_px, kWidth, kHeight, 4.0)) continue;
            ++points;
            const std::optional<Eigen::Vector3d> seen = truth.Point(cameras[1], right_px);
            if (!seen || (*seen - *X).norm() > 1e-3) continue;  // occluded in the right view
            ++same_point;
            // The disparity of a point 2-3 m away is f b / Z ~ 14-21 px (+-4 px from the
            // right camera's rotation).
            ASSERT_GT(u - right_px.x(), 7.0);
            ASSERT_LT(u - right_px.x(), 30.0);
            matched.push_back(std::abs(scene.left.At(u, v) - Bilinear(scene.right, right_px)));
            shifted.push_back(std::abs(
                scene.left.At(u, v) - Bilinear(scene.right, right_px + Eigen::Vector2d(2.0, 0.0))));
        }
    }
    ASSERT_GT(points, 1000);
    EXPECT_GT(same_point, 0.9 * points);
    const auto median = [](std::vector<double> values) {
        std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
        return values[values.size() / 2];
    };
    std::printf("points=%d same_point=%d median_abs_diff=%.2f shifted_2px=%.2f\n", points,
                same_point, median(matched), median(shifted));
    EXPECT_LT(median(matched), 4.0);  // noise sigma 2 in each image, sub-pixel texture
    EXPECT_GT(median(shifted), 2.0 * median(matched));
}

TEST(StereoRendererTest, SoilAndContainerCarryDifferentTextures) {
    const StereoScene& scene = PaperBucketScene();
    const SceneTruth truth(HalfFullPaperBucket(), scene.T_left_container);
    const PinholeCamera left = RigCameras(Rig(kWidth, kHeight))[0];
    Moments soil, container, background;
    for (int v = 0; v < kHeight; v += 2) {
        for (int u = 0; u < kWidth; u += 2) {
            const std::optional<int> material = truth.UniformMaterial(left, u, v);
            if (!material) continue;
            Moments& m = *material < 0                                           ? background
                         : *material == static_cast<int>(SurfaceMaterial::kSoil) ? soil
                                                                                 : container;
            m.Add(scene.left.At(u, v));
        }
    }
    std::printf(
        "soil_mean=%.1f soil_sigma=%.1f container_mean=%.1f container_sigma=%.1f "
        "background_mean=%.1f background_sigma=%.1f\n",
        soil.Mean(), soil.Sigma(), container.Mean(), container.Sigma(), background.Mean(),
        background.Sigma());
    ASSERT_GT(soil.n, 2000);
    ASSERT_GT(container.n, 2000);
    EXPECT_GT(soil.Sigma(), 12.0);
    EXPECT_GT(container.Sigma(), 12.0);
    EXPECT_GT(background.Sigma(), 12.0);
    EXPECT_GT(container.Mean() - soil.Mean(), 10.0);  // steel is lighter than soil
    EXPECT_GT(soil.Mean(), 40.0);
    EXPECT_LT(container.Mean(), 200.0);
}

TEST(StereoRendererTest, SameSpecGivesTheSameImages) {
    const SceneSpec spec = HalfFullPaperBucket();
    const StereoRigSpec rig = Rig(160, 120);
    const StereoScene a = RenderStereoScene(spec, rig);
    const StereoScene b = RenderStereoScene(spec, rig);
    EXPECT_EQ(a.left.pixels, b.left.pixels);
    EXPECT_EQ(a.right.pixels, b.right.pixels);
    EXPECT_NE(a.left.pixels, a.right.pixels);
    EXPECT_EQ(a.left.width, 160);
    EXPECT_EQ(a.left.pixels.size(), 160u * 120u);
}

TEST(StereoRendererTest, PixelNoiseHasTheGivenSigma) {
    // Without jitter the scan seed only changes the noise: the difference of two renders has
    // variance 2 (sigma^2 + 1/12) (the 1/12 from rounding).
    SceneSpec spec = HalfFullPaperBucket();
    StereoRigSpec rig = Rig(240, 180);
    rig.pixel_noise_sigma = 3.0;
    const StereoScene a = RenderStereoScene(spec, rig);
    spec.scan_seed = 2;
    const StereoScene b = RenderStereoScene(spec, rig);
    Moments difference;
    for (size_t i = 0; i < a.left.pixels.size(); ++i) {
        const int la = a.left.pixels[i], lb = b.left.pixels[i];
        if (la == 0 || la == 255 || lb == 0 || lb == 255) continue;  // clamped
        difference.Add(la - lb);
    }
    EXPECT_NEAR(difference.Sigma() / std::sqrt(2.0), std::sqrt(9.0 + 1.0 / 12.0), 0.1);
    EXPECT_NEAR(difference.Mean(), 0.0, 0.05);
    rig = Rig(80, 60);
    rig.pixel_noise_sigma = 0.0;
    EXPECT_EQ(RenderStereoScene(spec, rig).right.pixels,
              RenderStereoScene(HalfFullPaperBucket(), rig).right.pixels);
}

TEST(StereoRendererTest, TruckBedShowsSoilAndSteel) {
    SceneSpec spec;
    spec.container = ContainerKind::kTruckBed;
    spec.sensor = ViewpointFor(spec.container);
    spec.soil.fill_height_m = 0.4;
    Timer timer;
    const StereoScene scene = RenderStereoScene(spec, Rig(320, 240));
    std::printf("container=truck_bed width=320 height=240 supersampling=2 render_ms=%.0f\n",
                timer.Lap());
    const SceneTruth truth(spec, scene.T_left_container);
    const PinholeCamera left = RigCameras(Rig(320, 240))[0];
    int soil = 0, container = 0;
    for (int v = 0; v < 240; v += 4) {
        for (int u = 0; u < 320; u += 4) {
            const std::optional<RayHit> hit = truth.Hit(left, Eigen::Vector2d(u, v));
            if (hit) (hit->material == SurfaceMaterial::kSoil ? soil : container)++;
        }
    }
    EXPECT_GT(soil, 800);
    EXPECT_GT(container, 300);
    EXPECT_NEAR(scene.true_volume_m3, 4.0 * 2.2 * 0.4, 0.05);
}

}  // namespace
}  // namespace soilvol::sim
