#include <algorithm>
#include <cmath>
#include <random>

#include "core/sim/container_shell.hpp"
#include "core/sim/mesh_builder.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

class Draw {
  public:
    explicit Draw(uint64_t seed) : rng_(seed * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull) {}
    double operator()(double lo, double hi) {
        return std::uniform_real_distribution<double>(lo, hi)(rng_);
    }

  private:
    std::mt19937_64 rng_;
};

Profile ProfileOf(const ContainerShape& s) {
    switch (s.family) {
        case ContainerFamily::kBox:
        case ContainerFamily::kHighSideBin:
            return BoxProfile(s.width_m, s.depth_m);
        case ContainerFamily::kSlopedSymmetric:
        case ContainerFamily::kSlopedAsymmetric:
        case ContainerFamily::kFlaredBody:
            return SlopedProfile(s.width_m, s.depth_m, s.front_wall_deg, s.back_wall_deg);
        case ContainerFamily::kExcavator: {
            const double front_run =
                std::min(0.35 * s.width_m, s.depth_m / std::tan(s.front_wall_deg * kPi / 180.0));
            const double floor = std::min(s.floor_fraction * s.width_m, s.width_m - front_run);
            return ExcavatorProfile(s.width_m, s.depth_m, floor, front_run, 8);
        }
    }
    return BoxProfile(s.width_m, s.depth_m);
}

// Two lugs and a tilted cylinder on the back (+y) wall, at unequal x so that the outside pins
// the alignment's yaw.
void AddBucketLinkage(const ContainerShape& s, MeshBuilder* mesh) {
    const double hx = 0.5 * s.length_m, hy = 0.5 * s.width_m;
    const double reach = 0.2 + 0.15 * s.depth_m;
    mesh->AddBox({-0.55 * hx, hy, -0.7 * s.depth_m}, {-0.55 * hx + 0.05, hy + reach, 0.12});
    mesh->AddBox({0.25 * hx, hy, -0.7 * s.depth_m}, {0.25 * hx + 0.05, hy + reach, 0.12});
    const Eigen::Matrix3d tilt = (Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(-0.35, Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
    mesh->AddOrientedBox({0.7 * hx, hy + 0.5 * reach, -0.45 * s.depth_m}, {0.06, 0.18, 0.06}, tilt);
}

// Cab in front (-x) and chassis rails under the floor.
void AddBodyParts(const ContainerShape& s, MeshBuilder* mesh) {
    const double hx = 0.5 * s.length_m, hy = 0.5 * s.width_m;
    mesh->AddBox({-hx - 1.9, -0.9 * hy, -s.depth_m - 0.8}, {-hx - 0.25, 0.9 * hy, 0.5});
    mesh->AddBox({-hx - 2.3, -0.45, -s.depth_m - 0.35}, {hx + 0.1, -0.3, -s.depth_m - 0.1});
    mesh->AddBox({-hx - 2.3, 0.3, -s.depth_m - 0.35}, {hx + 0.1, 0.45, -s.depth_m - 0.1});
}

}  // namespace

const std::vector<ContainerFamily>& AllFamilies() {
    static const std::vector<ContainerFamily> kAll = {ContainerFamily::kBox,
                                                      ContainerFamily::kSlopedSymmetric,
                                                      ContainerFamily::kSlopedAsymmetric,
                                                      ContainerFamily::kExcavator,
                                                      ContainerFamily::kFlaredBody,
                                                      ContainerFamily::kHighSideBin};
    return kAll;
}

std::string FamilyName(ContainerFamily family) {
    switch (family) {
        case ContainerFamily::kBox:
            return "box";
        case ContainerFamily::kSlopedSymmetric:
            return "sloped symmetric";
        case ContainerFamily::kSlopedAsymmetric:
            return "sloped asymmetric";
        case ContainerFamily::kExcavator:
            return "excavator";
        case ContainerFamily::kFlaredBody:
            return "flared body";
        case ContainerFamily::kHighSideBin:
            return "high-side bin";
    }
    return "unknown";
}

ContainerShape RandomShape(ContainerFamily family, uint64_t seed) {
    Draw draw(seed * 16 + static_cast<uint64_t>(family));
    ContainerShape s;
    s.family = family;
    s.wall_m = draw(0.015, 0.04);
    s.rim_width_m = draw(0.03, 0.08);
    s.rim_thickness_m = draw(0.02, 0.05);
    switch (family) {
        case ContainerFamily::kBox:
            s.length_m = draw(0.8, 2.5);
            s.width_m = draw(0.5, 1.2);
            s.depth_m = draw(0.35, 0.8);
            break;
        case ContainerFamily::kSlopedSymmetric:
            s.length_m = draw(0.8, 2.5);
            s.width_m = draw(0.8, 1.4);
            s.depth_m = draw(0.4, 0.8);
            s.front_wall_deg = s.back_wall_deg = draw(55.0, 90.0);
            break;
        case ContainerFamily::kSlopedAsymmetric:
            s.length_m = draw(0.8, 2.5);
            s.width_m = draw(0.8, 1.4);
            s.depth_m = draw(0.4, 0.8);
            s.front_wall_deg = draw(55.0, 90.0);
            s.back_wall_deg = draw(55.0, 90.0);
            break;
        case ContainerFamily::kExcavator:
            s.length_m = draw(0.6, 2.5);
            s.width_m = draw(0.8, 1.4);
            s.depth_m = draw(0.5, 0.75) * s.width_m;
            s.front_wall_deg = draw(55.0, 75.0);
            s.floor_fraction = draw(0.25, 0.45);
            break;
        case ContainerFamily::kFlaredBody:
            s.length_m = draw(3.0, 6.0);
            s.width_m = draw(2.0, 2.6);
            s.depth_m = draw(0.8, 1.5);
            s.front_wall_deg = draw(65.0, 85.0);
            s.back_wall_deg = draw(65.0, 85.0);
            s.wall_m = draw(0.02, 0.05);
            break;
        case ContainerFamily::kHighSideBin:
            s.length_m = draw(1.0, 2.5);
            s.width_m = draw(0.8, 1.5);
            s.depth_m = draw(0.5, 1.0);
            s.high_side_m = draw(0.2, 0.6);
            break;
    }
    return s;
}

ContainerGeometry MakeContainer(const ContainerShape& s) {
    ContainerGeometry container;
    container.name = FamilyName(s.family);
    MeshBuilder mesh(&container.vertices, &container.triangles);
    ShellSpec shell;
    shell.length_m = s.length_m;
    shell.profile = ProfileOf(s);
    shell.wall_m = s.wall_m;
    shell.rim_width_m = s.rim_width_m;
    shell.rim_thickness_m = s.rim_thickness_m;
    AddShell(shell, &mesh);
    if (s.linkage) {
        if (s.family == ContainerFamily::kFlaredBody) {
            AddBodyParts(s, &mesh);
        } else {
            AddBucketLinkage(s, &mesh);
        }
    }
    if (s.high_side_m > 0.0) {
        const double hx = 0.5 * s.length_m + s.wall_m, hy = 0.5 * s.width_m;
        mesh.AddBox({-hx, hy, -0.01}, {hx, hy + s.wall_m, s.high_side_m});
    }
    SetOpening(shell, &container);
    return container;
}

SensorSpec ViewpointFor(const ContainerShape& shape, uint64_t seed) {
    Draw draw(seed * 31 + 7);
    SensorSpec sensor;
    const double size = std::max(shape.length_m, shape.width_m);
    const bool body = shape.family == ContainerFamily::kFlaredBody;
    sensor.distance_m = body ? std::clamp(1.1 * size, 4.0, 7.0) : std::clamp(1.3 * size, 2.0, 3.2);
    sensor.max_range_m = sensor.distance_m + 2.0 * size;
    sensor.elevation_deg = draw(50.0, 65.0);
    // Sensors look at the faces of the walls: over the low side of a high-side bin (azimuth 0
    // looks along +y), over an excavator bucket's back.
    const double base = shape.family == ContainerFamily::kExcavator ? 180.0 : 0.0;
    sensor.azimuth_deg = base + draw(-45.0, 45.0);
    return sensor;
}

std::vector<SensorSpec> BridgeViewpoints(const ContainerShape& shape, uint64_t seed) {
    Draw draw(seed * 53 + 11);
    SensorSpec near = ViewpointFor(shape, seed);
    near.elevation_deg = draw(60.0, 75.0);
    near.azimuth_deg = draw(-20.0, 20.0);
    SensorSpec far = near;
    far.azimuth_deg += 180.0;
    return {near, far};
}

}  // namespace soilvol::sim
