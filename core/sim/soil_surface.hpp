#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/sim/scene.hpp"

namespace soilvol::sim {

/// The soil in a container (container frame): surface s(x, y) = min(level + p(x, y), heap(x, y))
/// with level = fill_height_m - depth, p a cubic B-spline over a seeded control grid with values
/// uniform in [-perturbation_m, perturbation_m], and heap = heap_slope * distance to the nearest
/// opening edge. Soil fills inner surface < z < s inside the opening; fill_height_m <= 0 is empty.
class SoilSurface {
  public:
    SoilSurface(const ContainerGeometry& container, const SoilSpec& spec, uint64_t seed);

    bool Empty() const { return empty_; }
    /// Surface height s(x, y) [m], not clipped by the container.
    double SurfaceZ(double x, double y) const;
    /// Unit upward normal of the surface s at (x, y), by central differences.
    Eigen::Vector3d Normal(double x, double y) const;
    /// Whether the container-frame point lies inside the soil.
    bool Contains(const Eigen::Vector3d& p) const;
    /// z-range [m] of the top surface where it bounds soil (meaningless when empty).
    double SurfaceMinZ() const { return min_z_; }
    double SurfaceMaxZ() const { return max_z_; }
    /// Soil volume [m^3] by the midpoint rule on cells of at most `cell_m` (<= 0: 2 mm).
    double Volume(double cell_m) const;

  private:
    double Perturbation(double x, double y) const;
    double HeapZ(double x, double y) const;

    ContainerGeometry container_;
    double half_x_ = 0.0;
    double half_y_ = 0.0;
    double level_z_ = 0.0;
    double heap_slope_ = 0.0;
    bool empty_ = true;
    double min_z_ = 0.0;
    double max_z_ = 0.0;
    // Control grid: value (i, j) at (origin_x_ + i * cell_, origin_y_ + j * cell_), row-major in j.
    double cell_ = 0.0;
    double origin_x_ = 0.0;
    double origin_y_ = 0.0;
    int nx_ = 0;
    int ny_ = 0;
    std::vector<double> control_;
};

}  // namespace soilvol::sim
