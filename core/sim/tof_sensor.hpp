#pragma once

#include <random>

#include "core/common/types.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/scene_raycaster.hpp"

namespace soilvol::sim {

/// Container pose in the scan frame for the nominal view of `spec` (no jitter): the sensor sits
/// at distance_m from the opening centre, elevation_deg above the opening plane, azimuth_deg
/// counter-clockwise about +z from the -y side, looking at the opening centre (z forward,
/// x right, y down). Distances below 1 cm count as 1 cm.
Pose NominalScanPose(const SensorSpec& spec);

/// A time-of-flight sensor: rays on a regular azimuth/elevation grid about the optical axis
/// (steps of angular_resolution_deg; rows ring_spacing_deg apart when that is set: a spinning
/// lidar's rings), only those that cover the scene's bounding sphere.
class TofSensor {
  public:
    explicit TofSensor(const SensorSpec& spec);

    /// Scans `scene` (container frame) placed at `T_scan_container`; range noise and outliers
    /// come from `rng`. Points in the scan frame, row by row from the top; misses and returns
    /// beyond max_range_m are dropped. A non-positive angular resolution gives no points.
    Cloud Scan(const SceneRaycaster& scene, const Pose& T_scan_container,
               std::mt19937_64* rng) const;

  private:
    SensorSpec spec_;
};

/// A typical spinning lidar (32 beams over 42 deg: rings 1.33 deg apart, 0.2 deg along each,
/// 2 cm noise) at `viewpoint`, its spin axis tilted to face the container (the scan frame's
/// -y): the returns lie on rings with gaps between them that grow with range.
SensorSpec TypicalSpinningLidar(const SensorSpec& viewpoint);

}  // namespace soilvol::sim
