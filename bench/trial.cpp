#include "bench/trial.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <random>

#include "core/common/timer.hpp"
#include "core/depth/depth_scan.hpp"
#include "core/model/mesh_model.hpp"
#include "core/pipeline/registration.hpp"

namespace soilvol::bench {

sim::SensorSpec PaperSensor(sim::ContainerKind container) {
    sim::SensorSpec sensor = sim::ViewpointFor(container);
    sensor.range_noise_sigma_m = 0.04;
    sensor.angular_resolution_deg = 0.5;
    return sensor;
}

std::string ContainerName(sim::ContainerKind kind) { return sim::ContainerDescription(kind); }

namespace {

// The scan `spec` describes, taken by `setup`'s sensor: its ray grid, or its ToF camera's
// depth image back-projected as the service does.
sim::MultiSensorScene SimulateRig(const Setup& setup, const sim::SceneSpec& spec);

sim::Scene Simulate(const Setup& setup, const sim::SceneSpec& spec) {
    if (!setup.more_sensors.empty()) return SimulateRig(setup, spec).scene;
    if (!setup.tof_camera) return sim::SimulateScene(spec);
    sim::TofScene tof = sim::SimulateTofScene(spec, *setup.tof_camera);
    depth::DepthCamera camera;
    camera.intrinsics = tof.frame.intrinsics;
    camera.depth_unit_m = 1.0;
    depth::DepthScanConfig config;
    config.flying.noise_at_1m_m = setup.tof_camera->noise_at_1m_m;
    absl::StatusOr<depth::DepthCloud> cloud =
        depth::BackProject(tof.frame.depth, nullptr, camera, config, "scan.depth");
    if (cloud.ok()) tof.scene.points = std::move(cloud->points);
    return std::move(tof.scene);
}

sim::MultiSensorScene SimulateRig(const Setup& setup, const sim::SceneSpec& spec) {
    if (setup.more_sensors.empty()) return {Simulate(setup, spec), {}};
    // A rig turned with the first sensor (a second empty scan from the far side) turns whole.
    std::vector<sim::SensorSpec> more = setup.more_sensors;
    for (sim::SensorSpec& sensor : more) {
        sensor.azimuth_deg += spec.sensor.azimuth_deg - setup.sensor.azimuth_deg;
    }
    return sim::SimulateMultiSensorScene(spec, more);
}

sim::SceneSpec EmptySpec(const Setup& setup, uint64_t seed) {
    sim::SceneSpec spec;
    spec.container = setup.container;
    spec.shape = setup.shape;
    spec.sensor = setup.sensor;
    spec.jitter = setup.jitter;
    spec.soil_seed = seed;
    spec.scan_seed = seed * 1000;
    return spec;
}

}  // namespace

EmptyScanCase SimulateEmpty(const Setup& setup, uint64_t seed) {
    EmptyScanCase out{Simulate(setup, EmptySpec(setup, seed)), {}};
    out.corners = out.scene.opening_corners_scan;
    std::mt19937_64 rng(seed * 7919);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (auto& c : out.corners) {
        c += setup.corner_noise_m * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
    return out;
}

Setup FamilySetup(sim::ContainerFamily family, int seed, int empty_scans) {
    Setup setup;
    setup.empty_scans = empty_scans;
    setup.shape = sim::RandomShape(family, static_cast<uint64_t>(seed));
    setup.sensor = sim::ViewpointFor(*setup.shape, static_cast<uint64_t>(seed));
    constexpr std::array<double, 4> kNoise = {0.01, 0.02, 0.03, 0.04};
    constexpr std::array<double, 4> kResolution = {0.5, 0.35, 0.25, 0.4};
    constexpr std::array<double, 3> kOutliers = {0.0, 0.01, 0.02};
    const auto s = static_cast<std::size_t>(seed);
    setup.sensor.range_noise_sigma_m = kNoise[s % kNoise.size()];
    setup.sensor.angular_resolution_deg = kResolution[(s / 2) % kResolution.size()];
    setup.sensor.outlier_fraction = kOutliers[s % kOutliers.size()];
    setup.jitter = {5.0, 0.10};
    return setup;
}

RegisteredModel RegisterEmpty(const Setup& setup, uint64_t seed) {
    const sim::SceneSpec spec = EmptySpec(setup, seed);
    const EmptyScanCase marked = SimulateEmpty(setup, seed);
    const sim::Scene& empty = marked.scene;
    const Corners& corners = marked.corners;
    std::vector<pipeline::EmptyScan> scans = {
        {empty.points, std::nullopt, SimulateRig(setup, EmptySpec(setup, seed)).more}};
    for (int j = 1; j < setup.empty_scans; ++j) {
        sim::SceneSpec turned = spec;
        turned.sensor.azimuth_deg += 180.0;
        turned.scan_seed = spec.scan_seed + static_cast<uint64_t>(j) * 7;
        sim::MultiSensorScene other = SimulateRig(setup, turned);
        scans.push_back({std::move(other.scene.points), other.scene.opening_corners_scan,
                         std::move(other.more)});
    }
    RegisteredModel out{absl::UnknownError("not run"), empty.struck_capacity_m3, 0.0};
    Timer timer;
    if (setup.from_mesh) {
        const sim::ContainerGeometry geometry =
            setup.shape ? sim::MakeContainer(*setup.shape) : sim::MakeContainer(setup.container);
        out.model =
            model::BuildMeshModel({geometry.vertices, geometry.triangles}, geometry.opening_corners,
                                  empty.T_scan_container, setup.sensor.range_noise_sigma_m, {});
        out.register_ms = timer.Lap();
        if (out.model.ok()) {
            out.sim_to_model =
                empty.T_scan_container.inverse() * out.model->opening.T_scan_container;
        }
        return out;
    }
    auto reg = pipeline::RegisterContainer(corners, scans, pipeline::RegistrationConfig{});
    out.register_ms = timer.Lap();
    if (reg.ok()) {
        out.model = std::move(reg->model);
        out.sim_to_model = empty.T_scan_container.inverse() * out.model->opening.T_scan_container;
    } else {
        out.model = reg.status();
    }
    return out;
}

sim::Scene FilledScan(const Setup& setup, double fill_m, uint64_t seed, uint64_t scan_index) {
    return FilledRigScan(setup, fill_m, seed, scan_index).scene;
}

sim::MultiSensorScene FilledRigScan(const Setup& setup, double fill_m, uint64_t seed,
                                    uint64_t scan_index) {
    sim::SceneSpec spec;
    spec.container = setup.container;
    spec.shape = setup.shape;
    spec.sensor = setup.sensor;
    spec.jitter = setup.jitter;
    spec.move = setup.move;
    spec.soil.fill_height_m = fill_m;
    spec.soil.perturbation_m = setup.perturbation_m;
    spec.soil_seed = seed;
    spec.scan_seed = seed * 1000 + 1 + scan_index;
    return SimulateRig(setup, spec);
}

SizedScene SceneOfAbout(std::size_t points, uint64_t seed) {
    Setup setup;
    setup.sensor = PaperSensor(setup.container);
    SizedScene out{RegisterEmpty(setup, seed), {}, 0.0};
    // Returns grow with the inverse square of the angular step: two corrections land within
    // a few %.
    constexpr int kPasses = 3;
    for (int pass = 0; pass < kPasses; ++pass) {
        out.scene = FilledScan(setup, 0.3, seed, 0);
        const double ratio =
            static_cast<double>(std::max<std::size_t>(out.scene.points.size(), 1)) /
            static_cast<double>(points);
        if (pass + 1 == kPasses || std::abs(ratio - 1.0) < 0.03) break;
        setup.sensor.angular_resolution_deg *= std::sqrt(ratio);
    }
    out.angular_resolution_deg = setup.sensor.angular_resolution_deg;
    return out;
}

absl::StatusOr<pipeline::VolumeEstimate> Estimate(const model::ContainerModel& model,
                                                  const Cloud& scan, volume::Method method,
                                                  double cell_m,
                                                  const std::vector<SensorCloud>& more) {
    pipeline::EstimateConfig config;
    config.method = method;
    config.heightmap.cell_m = cell_m;
    config.paper.cell_m = cell_m > 0.0 ? cell_m : 0.10;
    return pipeline::EstimateVolume(model, scan, more, config);
}

}  // namespace soilvol::bench
