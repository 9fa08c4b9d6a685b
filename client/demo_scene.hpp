#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "core/sim/scene.hpp"
#include "core/sim/stereo_renderer.hpp"
#include "core/sim/tof_camera.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// What the demo's scans come from: the paper's time-of-flight sensor as clouds, a rendered
/// stereo rig, or a ToF camera's depth images.
enum class DemoSensor { kCloud, kStereo, kDepth };

/// The demo's simulated set-up, as soilvol-bench's demos: the paper's time-of-flight sensor
/// (4 cm, 0.5 deg), its 640x480 stereo rig with a 10 cm baseline, or a typical ToF camera
/// (sim::TypicalTofCamera), the container moved by up to 3 deg / 5 cm between scans.
struct DemoSetup {
    sim::ContainerKind kind = sim::ContainerKind::kPaperBucket;
    DemoSensor sensor = DemoSensor::kCloud;
    sim::TofCameraSpec camera = sim::TypicalTofCamera();  ///< for depth images
    uint64_t seed = 1;
    sim::SensorSpec view;  ///< the sensor; for stereo only its distance, elevation, azimuth
    sim::StereoRigSpec rig;
    sim::PoseJitter jitter{3.0, 0.05};
    double depth_m = 0.0;  ///< container depth: fills are shares of it
};

/// The set-up for `kind`; for stereo, the nearest distance from 2.5 m at which the opening
/// stays 40 px inside the image.
DemoSetup MakeDemoSetup(sim::ContainerKind kind, DemoSensor sensor, uint64_t seed);

/// One line describing the set-up.
std::string DescribeDemo(const DemoSetup& setup);

/// The rig's exact parameters for a CalibrateRequest.
v1::StereoParameters DemoRigParameters(const DemoSetup& setup);

/// A simulated scan ready to upload, with its exact truth.
struct DemoScan {
    v1::Scan scan;
    v1::Opening opening;  ///< true corners: 3D in the scan frame, or left-image pixels (stereo)
    /// Cloud and depth scans: the container's true pose in the scan frame (the frame of its
    /// mesh, DemoMesh, in the sensor's).
    v1::Pose container_pose;
    double true_volume_m3 = 0.0;
    double struck_capacity_m3 = 0.0;
    double heaped_capacity_m3 = 0.0;  ///< SAE J296
};

/// The simulated container's surface (the mesh the scans are cast from) in its own frame, with
/// its opening corners in that frame.
struct DemoMesh {
    std::string stl;  ///< binary STL [m]
    v1::Opening opening;
};
DemoMesh MakeDemoMesh(const DemoSetup& setup);

/// Scan number `scan_index` (0: the empty registration scan) with soil filled to `fill_share`
/// of the depth; stereo scans name `calibration_id`. Internal when an image cannot be encoded.
absl::StatusOr<DemoScan> SimulateDemoScan(const DemoSetup& setup, double fill_share,
                                          uint64_t scan_index, const std::string& calibration_id);

}  // namespace soilvol::client
