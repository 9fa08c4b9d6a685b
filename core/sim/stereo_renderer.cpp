#include "core/sim/stereo_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/sim/image_sensor.hpp"
#include "core/sim/pinhole_camera.hpp"
#include "core/sim/pose_jitter.hpp"
#include "core/sim/procedural_texture.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"
#include "core/sim/tof_sensor.hpp"

namespace soilvol::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kAmbient = 0.3;
constexpr double kExposure = 290.0;  // grey levels per unit radiance
constexpr uint64_t kLeftStream = 1;
constexpr uint64_t kRightStream = 2;

// The scene in the container frame as one camera sees it.
struct SceneView {
    const SceneRaycaster* raycaster = nullptr;
    Pose T_container_world;  // world = left camera frame
    uint32_t soil_seed = 0;
    double max_range_m = 0.0;
};

// Sun from above, a little to the -x/-y side (container frame).
const Eigen::Vector3d& LightDirection() {
    static const Eigen::Vector3d light = Eigen::Vector3d(-0.35, -0.45, 1.0).normalized();
    return light;
}

// Lambertian radiance along a container-frame ray, nullopt where it misses the scene.
std::optional<double> SurfaceRadiance(const SceneView& view, const Eigen::Vector3d& origin,
                                      const Eigen::Vector3d& direction) {
    const std::optional<RayHit> hit = view.raycaster->CastHit(origin, direction, view.max_range_m);
    if (!hit) return std::nullopt;
    const Eigen::Vector3d p = origin + hit->distance * direction;
    const double albedo =
        hit->material == SurfaceMaterial::kSoil ? SoilAlbedo(p, view.soil_seed) : SteelAlbedo(p);
    const double shading =
        kAmbient + (1.0 - kAmbient) * std::max(0.0, hit->normal.dot(LightDirection()));
    return albedo * shading;
}

// Box-filtered grey levels of `camera`'s image, supersampling^2 rays per pixel; rays that miss
// see the background at infinity, evaluated once per pixel (it is smooth at pixel scale).
std::vector<double> RenderView(const SceneView& view, const PinholeCamera& camera,
                               const StereoRigSpec& rig) {
    const int width = rig.image_width;
    const int height = rig.image_height;
    const int samples = std::max(rig.supersampling, 1);
    const Eigen::Vector3d origin = view.T_container_world * camera.Centre();
    std::vector<double> grey(static_cast<size_t>(width) * static_cast<size_t>(height));
#pragma omp parallel for schedule(dynamic, 2)
    for (int v = 0; v < height; ++v) {
        for (int u = 0; u < width; ++u) {
            double sum = 0.0;
            int misses = 0;
            Eigen::Vector3d miss_direction = Eigen::Vector3d::UnitZ();
            for (int j = 0; j < samples; ++j) {
                for (int i = 0; i < samples; ++i) {
                    const Eigen::Vector2d pixel(u + (i + 0.5) / samples - 0.5,
                                                v + (j + 0.5) / samples - 0.5);
                    const Eigen::Vector3d direction =
                        view.T_container_world.linear() * camera.Direction(pixel);
                    const std::optional<double> radiance = SurfaceRadiance(view, origin, direction);
                    if (radiance) {
                        sum += *radiance;
                    } else if (misses++ == 0) {
                        miss_direction = direction;
                    }
                }
            }
            if (misses > 0) sum += misses * SkyRadiance(miss_direction);
            grey[static_cast<size_t>(v) * width + u] = kExposure * sum / (samples * samples);
        }
    }
    return grey;
}

}  // namespace

StereoParameters RigParameters(const StereoRigSpec& rig) {
    StereoParameters parameters;
    parameters.image_width = rig.image_width;
    parameters.image_height = rig.image_height;
    const double focal = 0.5 * rig.image_width / std::tan(0.5 * rig.horizontal_fov_deg * kDegToRad);
    CameraIntrinsics intrinsics;
    intrinsics.fx = focal;
    intrinsics.fy = focal;
    intrinsics.cx = 0.5 * (rig.image_width - 1);
    intrinsics.cy = 0.5 * (rig.image_height - 1);
    intrinsics.distortion = rig.distortion;
    parameters.left = intrinsics;
    parameters.right = intrinsics;
    const Eigen::Vector3d rotation = rig.right_rotation_deg * kDegToRad;
    parameters.R_right_left =
        rotation.norm() > 0.0
            ? Eigen::AngleAxisd(rotation.norm(), rotation.normalized()).toRotationMatrix()
            : Eigen::Matrix3d::Identity();
    parameters.t_right_left_m =
        -parameters.R_right_left * Eigen::Vector3d(rig.baseline_m, 0.0, 0.0);
    return parameters;
}

Eigen::Vector2d ProjectLeft(const StereoRigSpec& rig, const Eigen::Vector3d& X_left) {
    return PinholeCamera(RigParameters(rig).left).Project(X_left);
}

Eigen::Vector2d ProjectRight(const StereoRigSpec& rig, const Eigen::Vector3d& X_left) {
    return RigCameras(rig)[1].Project(X_left);
}

StereoScene RenderStereoScene(const SceneSpec& spec, const StereoRigSpec& rig) {
    const ContainerGeometry container = MakeContainer(spec.container);
    const SoilSurface soil(container, spec.soil, spec.soil_seed);
    const SceneRaycaster raycaster(container, soil);
    std::mt19937_64 rng(spec.scan_seed);

    StereoScene scene;
    scene.parameters = RigParameters(rig);
    scene.T_left_container = NominalScanPose(spec.sensor) * JitterPose(spec.jitter, &rng);
    for (size_t i = 0; i < container.opening_corners.size(); ++i) {
        scene.opening_corners_left[i] = scene.T_left_container * container.opening_corners[i];
        scene.opening_corners_px[i] = ProjectLeft(rig, scene.opening_corners_left[i]);
    }
    scene.true_volume_m3 = TrueSoilVolume(container, spec.soil, spec.soil_seed);
    scene.struck_capacity_m3 = container.struck_capacity_m3;
    scene.heaped_capacity_sae_m3 = HeapedCapacity(container, 1.0);
    if (rig.image_width <= 0 || rig.image_height <= 0) return scene;

    // Render both views of the same scene, then expose each with its own noise stream.
    SceneView view;
    view.raycaster = &raycaster;
    view.T_container_world = scene.T_left_container.inverse();
    view.soil_seed = static_cast<uint32_t>(spec.soil_seed);
    const Eigen::AlignedBox3d bounds = raycaster.Bounds();
    view.max_range_m = (view.T_container_world.translation() - bounds.center()).norm() +
                       bounds.diagonal().norm() + 1.0;
    const std::array<PinholeCamera, 2> cameras = RigCameras(rig);
    scene.left = ExposeImage(RenderView(view, cameras[0], rig), rig.image_width, rig.image_height,
                             rig.pixel_noise_sigma, spec.scan_seed, kLeftStream);
    scene.right = ExposeImage(RenderView(view, cameras[1], rig), rig.image_width, rig.image_height,
                              rig.pixel_noise_sigma, spec.scan_seed, kRightStream);
    return scene;
}

double FramingDistance(ContainerKind kind, SensorSpec view, const StereoRigSpec& rig,
                       double margin_px) {
    const ContainerGeometry container = MakeContainer(kind);
    const double w = rig.image_width;
    const double h = rig.image_height;
    for (view.distance_m = 2.5; view.distance_m < 8.0; view.distance_m += 0.25) {
        const Pose T_left_container = NominalScanPose(view);
        bool inside = true;
        for (const Eigen::Vector3d& corner : container.opening_corners) {
            const Eigen::Vector2d px = ProjectLeft(rig, T_left_container * corner);
            inside = inside && px.allFinite() && px.x() > margin_px && px.y() > margin_px &&
                     px.x() < w - margin_px && px.y() < h - margin_px;
        }
        if (inside) break;
    }
    return view.distance_m;
}

}  // namespace soilvol::sim
