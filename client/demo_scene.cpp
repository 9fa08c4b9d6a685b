#include "client/demo_scene.hpp"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_format.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/mesh_codec.hpp"
#include "core/sim/stereo_renderer.hpp"
#include "core/sim/tof_sensor.hpp"
#include "core/stereo/image_codec.hpp"
#include "proto/convert/proto_convert.hpp"

namespace soilvol::client {
namespace {

absl::StatusOr<DemoScan> StereoScan(const sim::SceneSpec& spec, const DemoSetup& setup,
                                    const std::string& calibration_id) {
    const sim::StereoScene scene = sim::RenderStereoScene(spec, setup.rig);
    absl::StatusOr<std::string> left = stereo::EncodePng(scene.left);
    if (!left.ok()) return left.status();
    absl::StatusOr<std::string> right = stereo::EncodePng(scene.right);
    if (!right.ok()) return right.status();
    DemoScan out;
    out.scan.mutable_stereo()->set_left(*std::move(left));
    out.scan.mutable_stereo()->set_right(*std::move(right));
    out.scan.mutable_stereo()->set_calibration_id(calibration_id);
    for (const Eigen::Vector2d& px : scene.opening_corners_px) {
        v1::PixelPoint* corner = out.opening.add_pixel_corners();
        corner->set_u(px.x());
        corner->set_v(px.y());
    }
    out.true_volume_m3 = scene.true_volume_m3;
    out.struck_capacity_m3 = scene.struck_capacity_m3;
    out.heaped_capacity_m3 = scene.heaped_capacity_sae_m3;
    return out;
}

void AddCorners(const Corners& corners, v1::Opening* opening) {
    for (const Eigen::Vector3d& c : corners) {
        v1::Point3* corner = opening->add_corners();
        corner->set_x(c.x());
        corner->set_y(c.y());
        corner->set_z(c.z());
    }
}

DemoScan CloudScan(const sim::SceneSpec& spec) {
    const sim::Scene scene = sim::SimulateScene(spec);
    DemoScan out;
    out.scan.mutable_cloud()->set_data(io::EncodePly(scene.points));
    AddCorners(scene.opening_corners_scan, &out.opening);
    server::ToProto(scene.T_scan_container, &out.container_pose);
    out.true_volume_m3 = scene.true_volume_m3;
    out.struck_capacity_m3 = scene.struck_capacity_m3;
    out.heaped_capacity_m3 = scene.heaped_capacity_sae_m3;
    return out;
}

// The camera's frame as a 16-bit PNG in millimetres, as such cameras deliver it, with the
// camera's intrinsics.
absl::StatusOr<DemoScan> DepthScan(const sim::SceneSpec& spec, const DemoSetup& setup) {
    const sim::TofScene tof = sim::SimulateTofScene(spec, setup.camera);
    ScalarImage millimetres{tof.frame.depth.width, tof.frame.depth.height, 16, {}};
    millimetres.values.reserve(tof.frame.depth.values.size());
    for (const float z : tof.frame.depth.values) {
        millimetres.values.push_back(std::clamp(std::round(z * 1000.0f), 0.0f, 65535.0f));
    }
    absl::StatusOr<std::string> png = stereo::EncodeScalar(millimetres);
    if (!png.ok()) return png.status();
    DemoScan out;
    v1::DepthScan* depth = out.scan.mutable_depth();
    depth->set_depth(*std::move(png));
    depth->set_depth_noise_m(setup.camera.noise_at_1m_m);
    const CameraIntrinsics& k = tof.frame.intrinsics;
    depth->mutable_camera()->set_fx(k.fx);
    depth->mutable_camera()->set_fy(k.fy);
    depth->mutable_camera()->set_cx(k.cx);
    depth->mutable_camera()->set_cy(k.cy);
    AddCorners(tof.scene.opening_corners_scan, &out.opening);
    server::ToProto(tof.scene.T_scan_container, &out.container_pose);
    out.true_volume_m3 = tof.scene.true_volume_m3;
    out.struck_capacity_m3 = tof.scene.struck_capacity_m3;
    out.heaped_capacity_m3 = tof.scene.heaped_capacity_sae_m3;
    return out;
}

}  // namespace

DemoSetup MakeDemoSetup(sim::ContainerKind kind, DemoSensor sensor, uint64_t seed) {
    DemoSetup setup;
    setup.kind = kind;
    setup.sensor = sensor;
    setup.seed = seed;
    setup.view = sim::ViewpointFor(kind);
    setup.view.range_noise_sigma_m = 0.04;
    setup.view.angular_resolution_deg = 0.5;
    setup.depth_m = sim::MakeContainer(kind).depth_m;
    if (sensor == DemoSensor::kStereo) {
        setup.view.distance_m = sim::FramingDistance(setup.kind, setup.view, setup.rig);
    }
    return setup;
}

std::string DescribeDemo(const DemoSetup& setup) {
    if (setup.sensor == DemoSensor::kDepth) {
        return absl::StrFormat(
            "%s, simulated %dx%d ToF camera (%.0f mm noise at 1 m, flying pixels, multipath) "
            "%.2f m away, 16-bit depth images, container moved up to %.0f deg / %.0f cm between "
            "scans",
            sim::ContainerDescription(setup.kind), setup.camera.width, setup.camera.height,
            setup.camera.noise_at_1m_m * 1000, setup.view.distance_m, setup.jitter.max_rotation_deg,
            setup.jitter.max_translation_m * 100);
    }
    if (setup.sensor == DemoSensor::kStereo) {
        return absl::StrFormat(
            "%s, rendered %dx%d stereo pairs, %.0f cm baseline, %.2f m away, exact rig "
            "parameters, container moved up to %.0f deg / %.0f cm between pairs",
            sim::ContainerDescription(setup.kind), setup.rig.image_width, setup.rig.image_height,
            setup.rig.baseline_m * 100, setup.view.distance_m, setup.jitter.max_rotation_deg,
            setup.jitter.max_translation_m * 100);
    }
    return absl::StrFormat(
        "%s, simulated time-of-flight sensor (%.0f cm noise, %.1f deg) %.2f m away, container "
        "moved up to %.0f deg / %.0f cm between scans",
        sim::ContainerDescription(setup.kind), setup.view.range_noise_sigma_m * 100,
        setup.view.angular_resolution_deg, setup.view.distance_m, setup.jitter.max_rotation_deg,
        setup.jitter.max_translation_m * 100);
}

v1::StereoParameters DemoRigParameters(const DemoSetup& setup) {
    const StereoParameters exact = sim::RigParameters(setup.rig);
    v1::StereoParameters out;
    server::ToProto(exact, &out);
    return out;
}

DemoMesh MakeDemoMesh(const DemoSetup& setup) {
    const sim::ContainerGeometry geometry = sim::MakeContainer(setup.kind);
    io::DecodedMesh mesh;
    mesh.vertices = geometry.vertices;
    mesh.triangles = geometry.triangles;
    DemoMesh out;
    out.stl = io::EncodeStl(mesh);
    AddCorners(geometry.opening_corners, &out.opening);
    return out;
}

absl::StatusOr<DemoScan> SimulateDemoScan(const DemoSetup& setup, double fill_share,
                                          uint64_t scan_index, const std::string& calibration_id) {
    sim::SceneSpec spec;
    spec.container = setup.kind;
    spec.sensor = setup.view;
    spec.jitter = setup.jitter;
    spec.soil.fill_height_m = fill_share * setup.depth_m;
    spec.soil_seed = setup.seed;
    spec.scan_seed = setup.seed * 1000 + scan_index;
    switch (setup.sensor) {
        case DemoSensor::kStereo:
            return StereoScan(spec, setup, calibration_id);
        case DemoSensor::kDepth:
            return DepthScan(spec, setup);
        case DemoSensor::kCloud:
            break;
    }
    return CloudScan(spec);
}

}  // namespace soilvol::client
