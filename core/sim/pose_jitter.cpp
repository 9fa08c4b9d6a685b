#include "core/sim/pose_jitter.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d UniformUnitVector(std::mt19937_64* rng) {
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    const double z = uniform(*rng);
    const double phi = kPi * uniform(*rng);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

}  // namespace

Pose JitterPose(const PoseJitter& jitter, std::mt19937_64* rng) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    const Eigen::Vector3d axis = UniformUnitVector(rng);
    const double angle = std::max(jitter.max_rotation_deg, 0.0) * kPi / 180.0 * unit(*rng);
    const Eigen::Vector3d direction = UniformUnitVector(rng);
    const double radius = std::max(jitter.max_translation_m, 0.0) * std::cbrt(unit(*rng));
    Pose J = Pose::Identity();
    J.linear() = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
    J.translation() = radius * direction;
    return J;
}

}  // namespace soilvol::sim
