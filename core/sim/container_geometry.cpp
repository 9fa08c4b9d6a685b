#include <algorithm>
#include <cmath>
#include <utility>

#include "core/sim/container_shell.hpp"
#include "core/sim/mesh_builder.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Matrix3d RotationZX(double about_z_deg, double about_x_deg) {
    return (Eigen::AngleAxisd(about_z_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(about_x_deg * kPi / 180.0, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
}

// Linkage on the back (+y) wall: two lugs at unequal x and a tilted cylinder stub.
void AddPaperBucketLinkage(MeshBuilder* mesh) {
    const Profile lug = {{0.285, -0.45}, {0.50, -0.25}, {0.52, 0.02}, {0.42, 0.13}, {0.285, 0.10}};
    mesh->AddPrismX(lug, -0.62, -0.57);
    mesh->AddPrismX(lug, 0.28, 0.33);
    mesh->AddOrientedBox({0.75, 0.48, -0.30}, {0.06, 0.18, 0.06}, RotationZX(30.0, -20.0));
}

void AddExcavatorLinkage(const ShellSpec& shape, MeshBuilder* mesh) {
    const Profile lug = {{0.50, -0.18}, {0.75, -0.05}, {0.78, 0.12}, {0.62, 0.20}, {0.505, 0.10}};
    mesh->AddPrismX(lug, -0.33, -0.28);
    mesh->AddPrismX(lug, 0.10, 0.15);
    // Cylinder stub sunk into the back wall along its normal, about 60 deg up the arc.
    const Eigen::Vector2d& a = shape.profile[shape.profile.size() - 3];
    const Eigen::Vector2d& b = shape.profile[shape.profile.size() - 2];
    const Eigen::Vector2d normal = OutwardNormal(a, b);
    const Eigen::Vector2d foot = 0.5 * (a + b) + 0.8 * shape.wall_m * normal;
    const Eigen::Vector3d axis = Eigen::Vector3d(0.2, normal.x(), normal.y()).normalized();
    const Eigen::Matrix3d rotation =
        Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitY(), axis).toRotationMatrix();
    mesh->AddOrientedBox(Eigen::Vector3d(0.40, foot.x(), foot.y()) + 0.15 * axis,
                         {0.06, 0.15, 0.06}, rotation);
}

// Cab and hood in front (-x), chassis rails below, exhaust stack and fuel tank on one side.
void AddTruckParts(MeshBuilder* mesh) {
    mesh->AddBox({-3.75, -1.2, -1.55}, {-2.15, 1.2, 0.45});
    mesh->AddBox({-4.25, -1.15, -1.5}, {-3.75, 1.15, -0.7});
    mesh->AddBox({-4.25, -0.55, -1.1}, {2.25, -0.40, -0.83});
    mesh->AddBox({-4.25, 0.40, -1.1}, {2.25, 0.55, -0.83});
    mesh->AddBox({-2.25, 0.92, -0.9}, {-2.13, 1.04, 0.9});
    Profile tank;
    for (int i = 0; i < 8; ++i) {
        const double angle = (i + 0.5) * kPi / 4.0;
        tank.emplace_back(-0.8 + 0.25 * std::cos(angle), -1.06 + 0.25 * std::sin(angle));
    }
    mesh->AddPrismX(tank, -1.4, -0.5);
}

}  // namespace

double ContainerGeometry::InnerSurfaceZ(double x, double y) const {
    if (inner_profile_yz.size() < 2 || std::abs(x) >= 0.5 * opening_length_m ||
        std::abs(y) >= 0.5 * opening_width_m) {
        return 0.0;
    }
    const auto next =
        std::upper_bound(inner_profile_yz.begin(), inner_profile_yz.end(), y,
                         [](double value, const Eigen::Vector2d& p) { return value < p.x(); });
    if (next == inner_profile_yz.begin()) return next->y();
    if (next == inner_profile_yz.end()) return inner_profile_yz.back().y();
    const Eigen::Vector2d& a = *(next - 1);
    const Eigen::Vector2d& b = *next;
    return a.y() + (b.y() - a.y()) * (y - a.x()) / (b.x() - a.x());
}

ContainerGeometry MakeContainer(ContainerKind kind) {
    ContainerGeometry container;
    container.kind = kind;
    MeshBuilder mesh(&container.vertices, &container.triangles);
    ShellSpec shape;
    switch (kind) {
        case ContainerKind::kPaperBucket:
            container.name = "paper_bucket";
            shape.length_m = 2.05;
            shape.profile = BoxProfile(0.54, 0.6);
            AddPaperBucketLinkage(&mesh);
            break;
        case ContainerKind::kExcavatorBucket:
            container.name = "excavator_bucket";
            shape.length_m = 1.2;
            shape.profile = ExcavatorProfile(1.0, 0.75, 0.45, 0.2, 6);
            shape.rim_width_m = 0.05;
            AddExcavatorLinkage(shape, &mesh);
            break;
        case ContainerKind::kTruckBed:
            container.name = "truck_bed";
            shape.length_m = 4.0;
            shape.profile = BoxProfile(2.2, 0.8);
            shape.wall_m = 0.03;
            shape.rim_thickness_m = 0.05;
            AddTruckParts(&mesh);
            break;
    }
    AddShell(shape, &mesh);
    SetOpening(shape, &container);
    return container;
}

double HeapedCapacity(const ContainerGeometry& container, double heap_slope) {
    // Integral of the distance to the nearest edge over an L x W rectangle (L >= W).
    const double l = std::max(container.opening_length_m, container.opening_width_m);
    const double w = std::min(container.opening_length_m, container.opening_width_m);
    const double heap = w * w * l / 4.0 - w * w * w / 12.0;
    return container.struck_capacity_m3 + std::max(heap_slope, 0.0) * heap;
}

}  // namespace soilvol::sim
