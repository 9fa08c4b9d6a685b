#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/model/container_model.hpp"
#include "core/pipeline/estimator.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/tof_camera.hpp"

namespace soilvol::bench {

/// One simulated set-up: a container, a sensor, how much the container moves between scans.
struct Setup {
    sim::ContainerKind container = sim::ContainerKind::kPaperBucket;
    std::optional<sim::ContainerShape> shape;  ///< a random family member instead of `container`
    sim::SensorSpec sensor;
    sim::PoseJitter jitter{3.0, 0.05};  ///< the issue's "up to 3 deg, 5 cm"
    double corner_noise_m = 0.0;        ///< Gaussian error of the marked corners
    double perturbation_m = 0.02;       ///< soil surface perturbation amplitude
    /// Empty scans the model is registered from; each after the first sees the container
    /// turned half way round (the sensor's azimuth + 180 deg), its corners marked.
    int empty_scans = 1;
    /// Registered from the container's mesh (the simulator's, exact) instead of empty scans,
    /// placed where the first empty scan sees the container, with the sensor's range noise.
    bool from_mesh = false;
    /// A fixed move of the container before each filled scan (its own frame), on top of the
    /// jitter.
    Pose move = Pose::Identity();
    /// A ToF camera instead of `sensor`'s ray grid (`sensor` places it): each scan is its depth
    /// image, back-projected as the service does (core/depth, flying-pixel filter on).
    std::optional<sim::TofCameraSpec> tof_camera;
    /// Further sensors of a rig that scans together with `sensor` (a loading bridge's second
    /// lidar): every scan, empty and filled, is taken by all of them (not with a ToF camera).
    std::vector<sim::SensorSpec> more_sensors;
};

/// The paper's time-of-flight sensor (4 cm noise, 0.5 deg), placed 2.5-3 m away so that each
/// container's inside is mostly visible.
sim::SensorSpec PaperSensor(sim::ContainerKind container);

/// The families table's set-up for one seed: a random member of `family`, a viewpoint that sees
/// most of its inside, and a sensor whose noise (1-4 cm), resolution (0.25-0.5 deg) and
/// outliers (0-2%) cycle with the seed; moves up to 5 deg / 10 cm between scans.
Setup FamilySetup(sim::ContainerFamily family, int seed, int empty_scans = 1);

/// The container model registered from a simulated empty scan (seeded), with the truth.
struct RegisteredModel {
    absl::StatusOr<model::ContainerModel> model;
    double true_struck_m3 = 0.0;
    double register_ms = 0.0;
    /// The model's frame in the simulator's container frame: a filled scan's true pose in the
    /// model frame is its T_scan_container times this.
    Pose sim_to_model = Pose::Identity();
};
RegisteredModel RegisterEmpty(const Setup& setup, uint64_t seed);

/// The empty scan RegisterEmpty registers from, with its marked corners (noisy as configured):
/// what a benchmark of the server registers through the API.
struct EmptyScanCase {
    sim::Scene scene;
    Corners corners;
};
EmptyScanCase SimulateEmpty(const Setup& setup, uint64_t seed);

/// A filled scan of the same container (new pose, new noise) with its true volume.
sim::Scene FilledScan(const Setup& setup, double fill_m, uint64_t seed, uint64_t scan_index);

/// The same taken by every sensor of the set-up's rig (`more` empty without one).
sim::MultiSensorScene FilledRigScan(const Setup& setup, double fill_m, uint64_t seed,
                                    uint64_t scan_index);

/// A filled paper bucket (30 cm of soil) scanned by the paper's sensor made denser or sparser
/// until the scan holds about `points` returns (within a few %), and the model registered from
/// its usual 0.5 deg empty scan: the speed benchmarks' scenes.
struct SizedScene {
    RegisteredModel reg;
    sim::Scene scene;
    double angular_resolution_deg = 0.0;
};
SizedScene SceneOfAbout(std::size_t points, uint64_t seed = 1);

/// Estimates with `method` and `cell_m` (0 = automatic; the paper method needs a size).
absl::StatusOr<pipeline::VolumeEstimate> Estimate(const model::ContainerModel& model,
                                                  const Cloud& scan, volume::Method method,
                                                  double cell_m,
                                                  const std::vector<SensorCloud>& more = {});

std::string ContainerName(sim::ContainerKind kind);

}  // namespace soilvol::bench
