#include "core/cloud/sensor_frame.hpp"

namespace soilvol::cloud {

Cloud InSensorFrame(Cloud points, const Pose& sensor_pose) {
    if (sensor_pose.matrix() == Pose::Identity().matrix()) return points;
    const Eigen::Matrix3d R_sensor_cloud = sensor_pose.linear().transpose();
    const Eigen::Vector3d origin = sensor_pose.translation();
    for (Eigen::Vector3f& p : points) {
        p = (R_sensor_cloud * (p.cast<double>() - origin)).cast<float>();
    }
    return points;
}

}  // namespace soilvol::cloud
