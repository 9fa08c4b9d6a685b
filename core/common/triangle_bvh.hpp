#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>
#include <vector>

namespace soilvol {

/// First hit of a ray with a triangle: distance [m] and the triangle's unit normal (either side).
struct TriangleHit {
    double distance = 0.0;
    Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
};

/// Bounding volume hierarchy over a triangle mesh for first-hit ray queries (two-sided).
class TriangleBvh {
  public:
    TriangleBvh(const std::vector<Eigen::Vector3d>& vertices,
                const std::vector<Eigen::Vector3i>& triangles);

    /// Distance [m] along unit `direction` to the first triangle hit in (0, max_range), if any.
    std::optional<double> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                                    double max_range) const;
    /// The same first hit with the normal of the triangle hit.
    std::optional<TriangleHit> IntersectHit(const Eigen::Vector3d& origin,
                                            const Eigen::Vector3d& direction,
                                            double max_range) const;
    /// Bounds of the whole mesh (empty box for an empty mesh).
    const Eigen::AlignedBox3d& Bounds() const { return nodes_.front().box; }

  private:
    struct Triangle {
        Eigen::Vector3d v0, e1, e2;
    };
    struct Node {
        Eigen::AlignedBox3d box;
        int first = 0;  // leaf: first triangle; inner: left child
        int count = 0;  // leaf: number of triangles; inner: 0
        int right = 0;  // inner: right child
    };

    int Build(int first, int count);
    // Index of the first triangle hit (-1 on a miss), its distance in `best`.
    int FirstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                 double* best) const;

    std::vector<Triangle> triangles_;
    std::vector<Node> nodes_;
};

}  // namespace soilvol
