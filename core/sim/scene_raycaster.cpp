#include "core/sim/scene_raycaster.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace soilvol::sim {

namespace {

constexpr double kMarchStepM = 0.005;
constexpr double kBisectToleranceM = 1e-5;

// Parameter interval of the ray inside `box`, clipped to [0, max_range]; empty when t0 > t1.
std::pair<double, double> ClipToBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
                                    const Eigen::Vector3d& direction, double max_range) {
    double t0 = 0.0;
    double t1 = max_range;
    for (int a = 0; a < 3; ++a) {
        if (std::abs(direction[a]) < 1e-15) {
            if (origin[a] < box.min()[a] || origin[a] > box.max()[a]) return {1.0, 0.0};
            continue;
        }
        double near = (box.min()[a] - origin[a]) / direction[a];
        double far = (box.max()[a] - origin[a]) / direction[a];
        if (near > far) std::swap(near, far);
        t0 = std::max(t0, near);
        t1 = std::min(t1, far);
    }
    return {t0, t1};
}

}  // namespace

SceneRaycaster::SceneRaycaster(const ContainerGeometry& container, const SoilSurface& soil)
    : bvh_(container.vertices, container.triangles), soil_(soil) {
    if (soil_.Empty()) return;
    const double hx = 0.5 * container.opening_length_m;
    const double hy = 0.5 * container.opening_width_m;
    // A flat surface gives a box of zero height, whose samples would all lie on the surface
    // (inside or not by rounding): give it one march step of depth.
    const double max_z = soil_.SurfaceMaxZ();
    double min_z = soil_.SurfaceMinZ();
    if (!(max_z > min_z)) min_z = max_z - kMarchStepM;
    soil_box_ =
        Eigen::AlignedBox3d(Eigen::Vector3d(-hx, -hy, min_z), Eigen::Vector3d(hx, hy, max_z));
}

std::optional<double> SceneRaycaster::Cast(const Eigen::Vector3d& origin,
                                           const Eigen::Vector3d& direction,
                                           double max_range) const {
    const std::optional<double> mesh_hit = bvh_.Intersect(origin, direction, max_range);
    const std::optional<double> soil_hit =
        MarchSoil(origin, direction, mesh_hit.value_or(max_range));
    return soil_hit ? soil_hit : mesh_hit;
}

std::optional<RayHit> SceneRaycaster::CastHit(const Eigen::Vector3d& origin,
                                              const Eigen::Vector3d& direction,
                                              double max_range) const {
    const std::optional<TriangleHit> mesh_hit = bvh_.IntersectHit(origin, direction, max_range);
    const std::optional<double> soil_hit =
        MarchSoil(origin, direction, mesh_hit ? mesh_hit->distance : max_range);
    RayHit hit;
    if (soil_hit) {
        const Eigen::Vector3d p = origin + *soil_hit * direction;
        hit = {*soil_hit, soil_.Normal(p.x(), p.y()), SurfaceMaterial::kSoil};
    } else if (mesh_hit) {
        hit = {mesh_hit->distance, mesh_hit->normal, SurfaceMaterial::kContainer};
    } else {
        return std::nullopt;
    }
    if (hit.normal.dot(direction) > 0.0) hit.normal = -hit.normal;
    return hit;
}

Eigen::AlignedBox3d SceneRaycaster::Bounds() const {
    Eigen::AlignedBox3d bounds = bvh_.Bounds();
    if (!soil_box_.isEmpty()) bounds.extend(soil_box_);
    return bounds;
}

std::optional<double> SceneRaycaster::MarchSoil(const Eigen::Vector3d& origin,
                                                const Eigen::Vector3d& direction,
                                                double max_range) const {
    if (soil_box_.isEmpty()) return std::nullopt;
    const auto [t0, t1] = ClipToBox(soil_box_, origin, direction, max_range);
    if (t0 > t1) return std::nullopt;
    const auto inside = [&](double t) { return soil_.Contains(origin + t * direction); };
    if (inside(t0)) return t0;
    // March to the first sample inside the soil, then bisect the last step.
    const int steps = std::max(1, static_cast<int>(std::ceil((t1 - t0) / kMarchStepM)));
    double outside_t = t0;
    for (int k = 1; k <= steps; ++k) {
        double inside_t = t0 + (t1 - t0) * k / steps;
        if (!inside(inside_t)) {
            outside_t = inside_t;
            continue;
        }
        while (inside_t - outside_t > kBisectToleranceM) {
            const double mid = 0.5 * (outside_t + inside_t);
            (inside(mid) ? inside_t : outside_t) = mid;
        }
        return 0.5 * (outside_t + inside_t);
    }
    return std::nullopt;
}

}  // namespace soilvol::sim
