#include "core/sim/container_shell.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace soilvol::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Outer wall profile at distance `wall_m` (mitred joints); both ends end on z = 0.
Profile OuterProfile(const Profile& inner, double wall_m) {
    const size_t n = inner.size();
    Profile outer(n);
    for (size_t i = 1; i + 1 < n; ++i) {
        const Eigen::Vector2d n0 = OutwardNormal(inner[i - 1], inner[i]);
        const Eigen::Vector2d n1 = OutwardNormal(inner[i], inner[i + 1]);
        outer[i] = inner[i] + wall_m * (n0 + n1) / (1.0 + n0.dot(n1));
    }
    // The end points continue their segment to z = 0.
    for (const auto& [end, next] : {std::pair{size_t{0}, size_t{1}}, std::pair{n - 1, n - 2}}) {
        const Eigen::Vector2d u = (inner[next] - inner[end]).normalized();
        const Eigen::Vector2d normal = end == 0 ? OutwardNormal(inner[0], inner[1])
                                                : OutwardNormal(inner[n - 2], inner[n - 1]);
        const Eigen::Vector2d p = inner[end] + wall_m * normal;
        outer[end] = p + (std::abs(u.y()) > 1e-12 ? -p.y() / u.y() : 0.0) * u;
    }
    return outer;
}

// Area [m^2] between the profile and z = 0.
double ProfileArea(const Profile& profile) {
    double area = 0.0;
    for (size_t i = 0; i + 1 < profile.size(); ++i) {
        area -= 0.5 * (profile[i].y() + profile[i + 1].y()) * (profile[i + 1].x() - profile[i].x());
    }
    return area;
}

}  // namespace

Profile BoxProfile(double width_m, double depth_m) {
    const double hy = 0.5 * width_m;
    return {{-hy, 0.0}, {-hy, -depth_m}, {hy, -depth_m}, {hy, 0.0}};
}

Profile SlopedProfile(double width_m, double depth_m, double front_deg, double back_deg) {
    const double hy = 0.5 * width_m;
    const auto run = [&](double deg) {
        return deg >= 90.0 ? 0.0 : depth_m / std::tan(deg * kPi / 180.0);
    };
    double front = run(front_deg), back = run(back_deg);
    const double scale = std::min(1.0, 0.9 * width_m / std::max(front + back, 1e-9));
    front *= scale;
    back *= scale;
    return {{-hy, 0.0}, {-hy + front, -depth_m}, {hy - back, -depth_m}, {hy, 0.0}};
}

Profile ExcavatorProfile(double width_m, double depth_m, double floor_m, double front_run_m,
                         int arc_segments) {
    const double hy = 0.5 * width_m;
    const double floor_end = -hy + front_run_m + floor_m;
    Profile profile = {{-hy, 0.0}, {-hy + front_run_m, -depth_m}, {floor_end, -depth_m}};
    for (int i = 1; i <= arc_segments; ++i) {
        const double angle = 0.5 * kPi * i / arc_segments;
        profile.emplace_back(floor_end + (hy - floor_end) * std::sin(angle),
                             -depth_m * std::cos(angle));
    }
    profile.back() = {hy, 0.0};
    return profile;
}

Eigen::Vector2d OutwardNormal(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    const Eigen::Vector2d u = (b - a).normalized();
    return {u.y(), -u.x()};
}

// Walls and floor as one slab per profile segment, closed by two side plates, plus the rim.
void AddShell(const ShellSpec& shell, MeshBuilder* mesh) {
    const double hx = 0.5 * shell.length_m;
    const double t = shell.wall_m;
    const Profile outer = OuterProfile(shell.profile, t);
    for (size_t i = 0; i + 1 < shell.profile.size(); ++i) {
        mesh->AddPrismX({shell.profile[i], shell.profile[i + 1], outer[i + 1], outer[i]}, -hx - t,
                        hx + t);
    }
    mesh->AddPrismX(outer, hx, hx + t);
    mesh->AddPrismX(outer, -hx - t, -hx);

    const double hy = 0.5 * (shell.profile.back().x() - shell.profile.front().x());
    const double w = shell.rim_width_m;
    const double z0 = -shell.rim_thickness_m;
    mesh->AddBox({-hx - w, -hy - w, z0}, {hx + w, -hy, 0.0});
    mesh->AddBox({-hx - w, hy, z0}, {hx + w, hy + w, 0.0});
    mesh->AddBox({-hx - w, -hy, z0}, {-hx, hy, 0.0});
    mesh->AddBox({hx, -hy, z0}, {hx + w, hy, 0.0});
}

void SetOpening(const ShellSpec& shell, ContainerGeometry* container) {
    const double hx = 0.5 * shell.length_m;
    const double hy = 0.5 * (shell.profile.back().x() - shell.profile.front().x());
    container->opening_length_m = shell.length_m;
    container->opening_width_m = 2.0 * hy;
    container->opening_corners = {Eigen::Vector3d(-hx, -hy, 0.0), Eigen::Vector3d(hx, -hy, 0.0),
                                  Eigen::Vector3d(hx, hy, 0.0), Eigen::Vector3d(-hx, hy, 0.0)};
    container->inner_profile_yz = shell.profile;
    double min_z = 0.0;
    for (const Eigen::Vector2d& p : shell.profile) min_z = std::min(min_z, p.y());
    container->depth_m = -min_z;
    container->struck_capacity_m3 = shell.length_m * ProfileArea(shell.profile);
}

}  // namespace soilvol::sim
