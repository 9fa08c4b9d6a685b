#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

namespace soilvol {

/// A point cloud: 3D points [m] in the frame its owner names (scan frame unless stated).
using Cloud = std::vector<Eigen::Vector3f>;

/// Points with one weight each (same length; empty weights mean all 1), seen from `sensor`
/// (same frame): every point's ray runs from the sensor to it through free space.
struct WeightedCloud {
    Cloud points;
    std::vector<float> weights;
    Eigen::Vector3d sensor = Eigen::Vector3d::Zero();
};

/// A rigid transform; `T_a_b` maps points from frame b into frame a.
using Pose = Eigen::Isometry3d;

/// One sensor's returns in a scan several sensors took together: the points in the sensor's own
/// frame (the sensor at the origin) and the sensor's pose in the scan frame, the frame of the
/// scan's first sensor (x_scan = T_scan_sensor * x_sensor).
struct SensorCloud {
    Cloud points;
    Pose T_scan_sensor = Pose::Identity();
};

/// A triangle mesh [m]: vertices and the indices of each triangle's corners.
struct TriangleMesh {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<Eigen::Vector3i> triangles;
};

/// The four opening corners [m], ordered around the opening.
using Corners = std::array<Eigen::Vector3d, 4>;

}  // namespace soilvol
