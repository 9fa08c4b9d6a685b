#include "core/model/mesh_model.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/angles.hpp"
#include "core/common/status_macros.hpp"
#include "core/common/triangle_bvh.hpp"

namespace soilvol::model {
namespace {

TriangleMesh Transformed(const TriangleMesh& mesh, const Pose& T) {
    TriangleMesh out{{}, mesh.triangles};
    out.vertices.reserve(mesh.vertices.size());
    for (const Eigen::Vector3d& v : mesh.vertices) out.vertices.push_back(T * v);
    return out;
}

// A direction of a grid about `axis` (unit), `a` and `b` radians across it.
Eigen::Vector3d Direction(const Eigen::Matrix3d& basis, double a, double b) {
    return (basis.col(2) + std::tan(a) * basis.col(0) + std::tan(b) * basis.col(1)).normalized();
}

// Points on every triangle: a barycentric lattice of `n` steps a side.
Cloud SurfaceSamples(const TriangleMesh& mesh, int n) {
    Cloud out;
    for (const Eigen::Vector3i& t : mesh.triangles) {
        const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
        const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(t[1])];
        const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(t[2])];
        for (int i = 0; i <= n; ++i) {
            for (int j = 0; i + j <= n; ++j) {
                const double u = (i + 1.0 / 3.0) / (n + 1.0), v = (j + 1.0 / 3.0) / (n + 1.0);
                out.push_back((a + u * (b - a) + v * (c - a)).cast<float>());
            }
        }
    }
    return out;
}

constexpr int kSamplesPerSide = 4;

}  // namespace

Cloud CastMesh(const TriangleMesh& mesh, double step_deg, std::size_t max_rays) {
    Cloud out;
    if (mesh.triangles.empty()) return out;
    const TriangleBvh bvh(mesh.vertices, mesh.triangles);
    const Eigen::Vector3d centre = bvh.Bounds().center();
    const double radius = 0.5 * bvh.Bounds().diagonal().norm();
    const double distance = centre.norm();
    if (!(distance > radius)) return out;  // the sensor inside the mesh's bounds sees no view
    const double half = std::asin(radius / distance);
    Eigen::Matrix3d basis;
    basis.col(2) = centre / distance;
    const Eigen::Vector3d helper =
        std::abs(basis.col(2).z()) < 0.9 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    basis.col(0) = helper.cross(basis.col(2)).normalized();
    basis.col(1) = basis.col(2).cross(basis.col(0));
    double step = Radians(step_deg);
    const auto rays = [&](double s) { return std::pow(2.0 * half / s + 1.0, 2.0); };
    while (rays(step) > static_cast<double>(max_rays)) step *= 1.25;
    const int n = static_cast<int>(std::ceil(half / step));
    const double max_range = distance + radius;
    for (int i = -n; i <= n; ++i) {
        for (int j = -n; j <= n; ++j) {
            const Eigen::Vector3d d = Direction(basis, i * step, j * step);
            const std::optional<double> hit = bvh.Intersect(Eigen::Vector3d::Zero(), d, max_range);
            if (hit) out.push_back((*hit * d).cast<float>());
        }
    }
    return out;
}

volume::EmptySurface MeshEmptySurface(const TriangleMesh& mesh, const Polygon2d& opening,
                                      const volume::Grid& grid) {
    const TriangleBvh bvh(mesh.vertices, mesh.triangles);
    const double below = -bvh.Bounds().min().z() + 1.0;
    const auto n = static_cast<std::size_t>(grid.NumCells());
    volume::EmptySurface out;
    out.map.height.assign(n, std::nan(""));
    out.map.variance.assign(n, 0.0);
    out.map.support.assign(n, 0);
    out.map.observed.assign(n, 0.0);
    out.unobserved_sigma_m.assign(n, 0.0);
    out.map.noise_sigma_m = 0.0;
    constexpr int kSub = 4;
    const Eigen::Vector3d down(0.0, 0.0, -1.0);
    for (std::size_t k = 0; k < n; ++k) {
        if (grid.weight[k] <= 0.0) continue;
        out.area_m2 += grid.weight[k];
        const Eigen::Vector2d lo =
            grid.Center(static_cast<int>(k)) - Eigen::Vector2d::Constant(0.5 * grid.cell_m);
        double sum = 0.0;
        int hits = 0;
        for (int i = 0; i < kSub; ++i) {
            for (int j = 0; j < kSub; ++j) {
                const Eigen::Vector2d xy =
                    lo + grid.cell_m * Eigen::Vector2d((i + 0.5) / kSub, (j + 0.5) / kSub);
                if (!opening.Contains(xy)) continue;
                // From just under the opening plane down: the first surface is the inside.
                const std::optional<double> hit =
                    bvh.Intersect(Eigen::Vector3d(xy.x(), xy.y(), -1e-6), down, below);
                if (hit) sum += -1e-6 - *hit, ++hits;
            }
        }
        if (hits == 0) {
            // A cell whose part inside the opening no sample falls in: its anchor.
            const std::optional<double> hit = bvh.Intersect(
                Eigen::Vector3d(grid.anchor[k].x(), grid.anchor[k].y(), -1e-6), down, below);
            if (!hit) continue;
            sum = -1e-6 - *hit, hits = 1;
        }
        out.map.height[k] = sum / hits;
        out.map.support[k] = 1;
        out.map.observed[k] = static_cast<double>(hits) / (kSub * kSub);
        out.observed_area_m2 += grid.weight[k];
        ++out.map.measured;
    }
    return out;
}

absl::StatusOr<ContainerModel> BuildMeshModel(const TriangleMesh& mesh, const Corners& corners_mesh,
                                              const Pose& T_scan_mesh, double range_noise_m,
                                              const MeshModelConfig& config,
                                              const StopToken& stop) {
    if (!(range_noise_m >= config.min_noise_m && range_noise_m <= config.max_noise_m)) {
        return absl::InvalidArgumentError(
            absl::StrFormat("range_noise_m: the sensor's range noise must lie in [%g, %g] m",
                            config.min_noise_m, config.max_noise_m));
    }
    // The mesh as the sensor sees it, with the sensor's range noise: the alignment set and the
    // structure are smoothed as every scan's returns are, and smoothing moves a surface's edges
    // by what the noise spreads (seeded: the same mesh gives the same model).
    const TriangleMesh in_scan = Transformed(mesh, T_scan_mesh);
    Cloud virtual_scan = CastMesh(in_scan, config.angular_step_deg, config.max_virtual_rays);
    std::mt19937_64 rng(config.noise_seed);
    std::normal_distribution<float> noise(0.0f, static_cast<float>(range_noise_m));
    for (Eigen::Vector3f& p : virtual_scan) p += noise(rng) * p.normalized();
    SOILVOL_RETURN_IF_ERROR(stop.Check("virtual scan of the mesh"));
    if (virtual_scan.empty()) {
        return absl::InvalidArgumentError(
            "mesh: the sensor sees none of it at the given pose (is the pose the container's in "
            "the sensor's frame, and the mesh in metres?)");
    }
    // The sensor sees the inside from above the opening plane, as in any empty scan.
    {
        Cloud samples = SurfaceSamples(mesh, kSamplesPerSide);
        auto placed = MakeOpening(corners_mesh, samples, config.model.opening);
        if (!placed.ok()) {
            return absl::InvalidArgumentError(
                absl::StrCat("mesh.corners: ", placed.status().message()));
        }
        const Pose T_scan_container = T_scan_mesh * placed->T_scan_container;
        if (T_scan_container.inverse().translation().z() <= 0.0) {
            return absl::InvalidArgumentError(
                "container_pose: the sensor lies below the opening plane at this pose and cannot "
                "see the inside (is it the mesh frame in the sensor's frame?)");
        }
    }
    Corners corners_scan;
    for (std::size_t i = 0; i < corners_mesh.size(); ++i)
        corners_scan[i] = T_scan_mesh * corners_mesh[i];
    ModelConfig model_config = config.model;
    model_config.noise_sigma_m = range_noise_m;
    SOILVOL_ASSIGN_OR_RETURN(ContainerModel model,
                             BuildContainerModel(virtual_scan, corners_scan, model_config, stop));
    // The exact inside replaces the one fitted to the virtual scan.
    model.mesh = Transformed(in_scan, model.opening.T_scan_container.inverse());
    model.walls.clear();
    SOILVOL_RETURN_IF_ERROR(UpdateCapacities(model_config, model, stop));
    return model;
}

absl::Status AttachMesh(const TriangleMesh& mesh, const Corners& corners_mesh,
                        const ModelConfig& config, ContainerModel& model, double max_mismatch_m,
                        const StopToken& stop) {
    // Which side is the inside: where the mesh's surface lies over the opening (its samples; a
    // coarse CAD mesh may have no vertex there).
    auto opening = MakeOpening(corners_mesh, SurfaceSamples(mesh, kSamplesPerSide), config.opening);
    if (!opening.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("mesh.opening: ", opening.status().message()));
    }
    // Corner by corner, the two openings in their own frames agree.
    const auto& a = opening->polygon.Vertices();
    const auto& b = model.opening.polygon.Vertices();
    double worst = 0.0;
    for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i) {
        const int corner = opening->corner_of_vertex[i];
        const auto j =
            static_cast<std::size_t>(std::find(model.opening.corner_of_vertex.begin(),
                                               model.opening.corner_of_vertex.end(), corner) -
                                     model.opening.corner_of_vertex.begin());
        if (j < b.size()) worst = std::max(worst, (a[i] - b[j]).norm());
    }
    const double area_ratio = opening->area_m2 / std::max(model.opening.area_m2, 1e-12);
    if (worst > max_mismatch_m || std::abs(area_ratio - 1.0) > 0.05) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "mesh.opening: the mesh's opening (%.3f m2) differs from the scan's (%.3f m2) by "
            "%.3f m at a corner (at most %.3f m): mark the same corners in the same order on both",
            opening->area_m2, model.opening.area_m2, worst, max_mismatch_m));
    }
    model.mesh = Transformed(mesh, opening->T_scan_container.inverse());
    model.walls.clear();
    return UpdateCapacities(config, model, stop);
}

}  // namespace soilvol::model
