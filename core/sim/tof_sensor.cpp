#include "core/sim/tof_sensor.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace soilvol::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kMaxConeRad = 80.0 * kDegToRad;
constexpr double kMaxElevationRad = 89.0 * kDegToRad;
constexpr double kMarginRad = 1.0 * kDegToRad;
constexpr double kMinOutlierRangeM = 0.3;

// Unit ray direction in the scan frame (x right, y down, z forward).
Eigen::Vector3d RayDirection(double azimuth, double elevation) {
    return {std::cos(elevation) * std::sin(azimuth), -std::sin(elevation),
            std::cos(elevation) * std::cos(azimuth)};
}

// Rays whose direction lies within `cone` of the unit `axis`, as grid rows of (azimuth,
// elevation): rows `row_step` apart in elevation, columns `column_step` apart in azimuth.
struct RayGrid {
    double row_step = 0.0;
    double column_step = 0.0;
    double axis_azimuth = 0.0;
    double axis_elevation = 0.0;
    double cone = 0.0;

    std::pair<int, int> Rows() const {
        const double lo = std::max(axis_elevation - cone, -kMaxElevationRad);
        const double hi = std::min(axis_elevation + cone, kMaxElevationRad);
        return {static_cast<int>(std::ceil(lo / row_step)),
                static_cast<int>(std::floor(hi / row_step))};
    }

    // Columns of row `j`: cos(a - a_c) >= (cos cone - sin e sin e_c) / (cos e cos e_c).
    std::pair<int, int> Columns(int j) const {
        const double e = j * row_step;
        const double bound = (std::cos(cone) - std::sin(e) * std::sin(axis_elevation)) /
                             (std::cos(e) * std::cos(axis_elevation));
        if (bound > 1.0) return {1, 0};
        const double half = bound < -1.0 ? kPi : std::acos(bound);
        const double lo = std::max(axis_azimuth - half, -kPi);
        const double hi = std::min(axis_azimuth + half, kPi - 1e-9);
        return {static_cast<int>(std::ceil(lo / column_step)),
                static_cast<int>(std::floor(hi / column_step))};
    }
};

RayGrid CoverBoundingSphere(const Eigen::AlignedBox3d& bounds, const Pose& T_scan_container,
                            double row_step, double column_step) {
    const Eigen::Vector3d centre = T_scan_container * bounds.center();
    const double radius = 0.5 * bounds.diagonal().norm();
    const double distance = centre.norm();
    RayGrid grid;
    grid.row_step = row_step;
    grid.column_step = column_step;
    grid.axis_azimuth = std::atan2(centre.x(), centre.z());
    grid.axis_elevation = std::atan2(-centre.y(), std::hypot(centre.x(), centre.z()));
    const double cone = distance > radius ? std::asin(radius / distance) : kMaxConeRad;
    grid.cone = std::min(cone + kMarginRad + std::max(row_step, column_step), kMaxConeRad);
    return grid;
}

}  // namespace

Pose NominalScanPose(const SensorSpec& spec) {
    const double distance = std::max(spec.distance_m, 0.01);
    const double elevation = spec.elevation_deg * kDegToRad;
    const Eigen::Matrix3d about_z =
        Eigen::AngleAxisd(spec.azimuth_deg * kDegToRad, Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    const Eigen::Vector3d sensor =
        about_z * Eigen::Vector3d(0.0, -std::cos(elevation), std::sin(elevation)) * distance;
    Pose T_container_scan = Pose::Identity();
    const Eigen::Vector3d axis_z = -sensor.normalized();
    const Eigen::Vector3d axis_x = about_z.col(0);
    T_container_scan.linear() << axis_x, axis_z.cross(axis_x), axis_z;
    T_container_scan.translation() = sensor;
    return T_container_scan.inverse();
}

TofSensor::TofSensor(const SensorSpec& spec) : spec_(spec) {}

Cloud TofSensor::Scan(const SceneRaycaster& scene, const Pose& T_scan_container,
                      std::mt19937_64* rng) const {
    Cloud points;
    if (!(spec_.angular_resolution_deg > 0.0)) return points;
    const double column_step = spec_.angular_resolution_deg * kDegToRad;
    const double row_step =
        spec_.ring_spacing_deg > 0.0 ? spec_.ring_spacing_deg * kDegToRad : column_step;
    const RayGrid grid =
        CoverBoundingSphere(scene.Bounds(), T_scan_container, row_step, column_step);
    const Pose T_container_scan = T_scan_container.inverse();
    const Eigen::Vector3d origin = T_container_scan.translation();
    const double sigma = std::max(spec_.range_noise_sigma_m, 0.0);
    const double cast_range = spec_.max_range_m + 5.0 * sigma;
    std::normal_distribution<double> noise(0.0, sigma > 0.0 ? sigma : 1.0);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::uniform_real_distribution<double> outlier_range(
        kMinOutlierRangeM, std::max(spec_.max_range_m, kMinOutlierRangeM));
    const auto [first_row, last_row] = grid.Rows();
    for (int j = last_row; j >= first_row; --j) {
        const auto [first_col, last_col] = grid.Columns(j);
        for (int k = first_col; k <= last_col; ++k) {
            const Eigen::Vector3d ray = RayDirection(k * grid.column_step, j * grid.row_step);
            const std::optional<double> hit =
                scene.Cast(origin, T_container_scan.linear() * ray, cast_range);
            if (!hit) continue;
            // Range noise along the ray, or a random range for an outlier.
            double range = *hit;
            if (spec_.outlier_fraction > 0.0 && unit(*rng) < spec_.outlier_fraction) {
                range = outlier_range(*rng);
            } else if (sigma > 0.0) {
                range += noise(*rng);
            }
            if (range <= 0.0 || range > spec_.max_range_m) continue;
            points.push_back((range * ray).cast<float>());
        }
    }
    return points;
}

SensorSpec TypicalSpinningLidar(const SensorSpec& viewpoint) {
    SensorSpec lidar = viewpoint;
    lidar.ring_spacing_deg = 1.33;
    lidar.angular_resolution_deg = 0.2;
    lidar.range_noise_sigma_m = 0.02;
    lidar.outlier_fraction = 0.0;
    return lidar;
}

}  // namespace soilvol::sim
