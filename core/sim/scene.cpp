#include "core/sim/scene.hpp"

#include <random>

#include "core/sim/pose_jitter.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"
#include "core/sim/tof_sensor.hpp"

namespace soilvol::sim {

namespace {

constexpr double kTruthCellM = 0.002;

}  // namespace

SensorSpec ViewpointFor(ContainerKind kind) {
    SensorSpec sensor;
    switch (kind) {
        case ContainerKind::kPaperBucket:
            sensor.elevation_deg = 55.0;
            sensor.azimuth_deg = 60.0;
            break;
        case ContainerKind::kExcavatorBucket:
            sensor.elevation_deg = 65.0;
            sensor.azimuth_deg = 200.0;
            break;
        case ContainerKind::kTruckBed:
            sensor.distance_m = 5.0;
            sensor.elevation_deg = 60.0;
            sensor.azimuth_deg = 70.0;
            sensor.max_range_m = 12.0;
            break;
    }
    return sensor;
}

Scene PlaceScene(const SceneSpec& spec, const ContainerGeometry& container, const SoilSurface& soil,
                 std::mt19937_64* rng) {
    Scene scene;
    scene.T_scan_container =
        NominalScanPose(spec.sensor) * spec.move * JitterPose(spec.jitter, rng);
    for (size_t i = 0; i < container.opening_corners.size(); ++i) {
        scene.opening_corners_scan[i] = scene.T_scan_container * container.opening_corners[i];
    }
    scene.true_volume_m3 = soil.Volume(kTruthCellM);
    scene.struck_capacity_m3 = container.struck_capacity_m3;
    scene.heaped_capacity_sae_m3 = HeapedCapacity(container, 1.0);
    scene.heaped_capacity_iso_m3 = HeapedCapacity(container, 0.5);
    return scene;
}

Scene SimulateScene(const SceneSpec& spec) {
    const ContainerGeometry container =
        spec.shape ? MakeContainer(*spec.shape) : MakeContainer(spec.container);
    const SoilSurface soil(container, spec.soil, spec.soil_seed);
    std::mt19937_64 rng(spec.scan_seed);
    Scene scene = PlaceScene(spec, container, soil, &rng);
    scene.points =
        TofSensor(spec.sensor).Scan(SceneRaycaster(container, soil), scene.T_scan_container, &rng);
    return scene;
}

MultiSensorScene SimulateMultiSensorScene(const SceneSpec& spec,
                                          const std::vector<SensorSpec>& more) {
    const ContainerGeometry container =
        spec.shape ? MakeContainer(*spec.shape) : MakeContainer(spec.container);
    const SoilSurface soil(container, spec.soil, spec.soil_seed);
    const SceneRaycaster raycaster(container, soil);
    std::mt19937_64 rng(spec.scan_seed);
    MultiSensorScene out;
    out.scene = PlaceScene(spec, container, soil, &rng);
    out.scene.points = TofSensor(spec.sensor).Scan(raycaster, out.scene.T_scan_container, &rng);
    // The container's pose without the first sensor's viewpoint: where the rig finds it.
    const Pose T_nominal_container =
        NominalScanPose(spec.sensor).inverse() * out.scene.T_scan_container;
    for (std::size_t i = 0; i < more.size(); ++i) {
        const Pose T_sensor_container = NominalScanPose(more[i]) * T_nominal_container;
        std::mt19937_64 own(spec.scan_seed * 7919 + i + 1);
        out.more.push_back({TofSensor(more[i]).Scan(raycaster, T_sensor_container, &own),
                            out.scene.T_scan_container * T_sensor_container.inverse()});
    }
    return out;
}

double TrueSoilVolume(const ContainerGeometry& container, const SoilSpec& soil,
                      uint64_t soil_seed) {
    return SoilSurface(container, soil, soil_seed).Volume(kTruthCellM);
}

std::string ContainerDescription(ContainerKind kind) {
    switch (kind) {
        case ContainerKind::kPaperBucket:
            return "paper bucket 2.05x0.54x0.6 m";
        case ContainerKind::kExcavatorBucket:
            return "excavator bucket 1.2x1.0 m, sloped";
        case ContainerKind::kTruckBed:
            return "truck bed 4.0x2.2x0.8 m";
    }
    return "unknown container";
}

}  // namespace soilvol::sim
