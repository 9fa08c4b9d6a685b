#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

namespace soilvol::sim {

/// Appends closed convex solids to a triangle mesh (outward-facing triangles).
class MeshBuilder {
  public:
    MeshBuilder(std::vector<Eigen::Vector3d>* vertices, std::vector<Eigen::Vector3i>* triangles);

    /// Prism swept by a convex planar polygon (>= 3 vertices, either winding) along `extrusion`.
    void AddPrism(const std::vector<Eigen::Vector3d>& polygon, const Eigen::Vector3d& extrusion);
    /// Prism of a convex polygon in the y-z plane, extruded along x from x0 to x1.
    void AddPrismX(const std::vector<Eigen::Vector2d>& polygon_yz, double x0, double x1);
    /// Axis-aligned box between two corners.
    void AddBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max);
    /// Box with half extents `half` along the columns of `rotation`, centred at `centre`.
    void AddOrientedBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                        const Eigen::Matrix3d& rotation);

  private:
    std::vector<Eigen::Vector3d>* vertices_;
    std::vector<Eigen::Vector3i>* triangles_;
};

}  // namespace soilvol::sim
