#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

namespace soilvol {

/// A simple polygon in the plane [m], stored counter-clockwise.
class Polygon2d {
  public:
    Polygon2d() = default;
    /// Takes the vertices in either orientation; stores them counter-clockwise.
    explicit Polygon2d(std::vector<Eigen::Vector2d> vertices);

    const std::vector<Eigen::Vector2d>& Vertices() const { return vertices_; }
    /// Area [m^2].
    double Area() const;
    /// Even-odd point-in-polygon test.
    bool Contains(const Eigen::Vector2d& p) const;
    /// Area [m^2] of the intersection with the axis-aligned rectangle [lo, hi].
    double ClippedArea(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const;
    /// Area [m^2] and centroid of the intersection with the rectangle [lo, hi]; the centroid is
    /// the rectangle's centre when the intersection is empty.
    std::pair<double, Eigen::Vector2d> Clip(const Eigen::Vector2d& lo,
                                            const Eigen::Vector2d& hi) const;
    /// Distance [m] from `p` to the nearest edge.
    double DistanceToBoundary(const Eigen::Vector2d& p) const;
    /// Axis-aligned bounding box.
    Eigen::Vector2d Min() const;
    Eigen::Vector2d Max() const;
    /// True when no two non-adjacent edges intersect.
    bool IsSimple() const;
    /// Integral over the polygon of the distance to the boundary [m^3] (heap volume at slope 1).
    double DistanceIntegral(int samples_per_axis = 600) const;

  private:
    std::vector<Eigen::Vector2d> vertices_;
};

/// Signed area [m^2] of a closed vertex loop (positive when counter-clockwise).
double SignedArea(const std::vector<Eigen::Vector2d>& vertices);

}  // namespace soilvol
