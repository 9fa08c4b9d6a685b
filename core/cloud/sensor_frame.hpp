#pragma once

#include "core/common/types.hpp"

namespace soilvol::cloud {

/// `points`, given in a frame where the sensor sits at `sensor_pose` (x_cloud = sensor_pose *
/// x_sensor: a vehicle's or a site's frame), mapped into the sensor's own frame, where every
/// ray-based step expects them (the sensor at the origin). Computed in double and rounded once;
/// the identity returns the points untouched.
Cloud InSensorFrame(Cloud points, const Pose& sensor_pose);

}  // namespace soilvol::cloud
