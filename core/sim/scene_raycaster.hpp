#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

#include "core/common/triangle_bvh.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/soil_surface.hpp"

namespace soilvol::sim {

/// What a ray hit.
enum class SurfaceMaterial { kContainer, kSoil };

/// A first hit: distance [m] along the ray, unit surface normal facing the ray origin, material.
struct RayHit {
    double distance = 0.0;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
    SurfaceMaterial material = SurfaceMaterial::kContainer;
};

/// First-hit ray queries against a container mesh and its soil, in the container frame.
class SceneRaycaster {
  public:
    SceneRaycaster(const ContainerGeometry& container, const SoilSurface& soil);

    /// Distance [m] along unit `direction` to the first hit of the mesh or the soil surface in
    /// (0, max_range), if any. The soil is found by marching in steps of at most 5 mm and
    /// bisecting to 0.01 mm.
    std::optional<double> Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                               double max_range) const;
    /// The hit Cast finds (same distance), with its normal and material.
    std::optional<RayHit> CastHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                  double max_range) const;
    /// Box that holds the mesh and the soil.
    Eigen::AlignedBox3d Bounds() const;

  private:
    std::optional<double> MarchSoil(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                    double max_range) const;

    TriangleBvh bvh_;
    SoilSurface soil_;
    Eigen::AlignedBox3d soil_box_;  // where the soil surface can be; empty without soil
};

}  // namespace soilvol::sim
