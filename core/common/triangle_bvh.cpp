#include "core/common/triangle_bvh.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace soilvol {

namespace {

constexpr int kLeafSize = 4;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Moller-Trumbore; distance along the ray or a negative value on a miss.
template <typename Triangle>
double HitTriangle(const Triangle& tri, const Eigen::Vector3d& origin,
                   const Eigen::Vector3d& direction) {
    const Eigen::Vector3d p = direction.cross(tri.e2);
    const double det = tri.e1.dot(p);
    if (std::abs(det) < 1e-14) return -1.0;
    const double inv_det = 1.0 / det;
    const Eigen::Vector3d s = origin - tri.v0;
    const double u = s.dot(p) * inv_det;
    if (u < 0.0 || u > 1.0) return -1.0;
    const Eigen::Vector3d q = s.cross(tri.e1);
    const double v = direction.dot(q) * inv_det;
    if (v < 0.0 || u + v > 1.0) return -1.0;
    return tri.e2.dot(q) * inv_det;
}

// Slab test; entry distance or infinity on a miss.
double HitBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& origin,
              const Eigen::Vector3d& inv_direction, double max_range) {
    double t0 = 0.0;
    double t1 = max_range;
    for (int a = 0; a < 3; ++a) {
        double near = (box.min()[a] - origin[a]) * inv_direction[a];
        double far = (box.max()[a] - origin[a]) * inv_direction[a];
        if (near > far) std::swap(near, far);
        t0 = std::max(t0, near);
        t1 = std::min(t1, far);
        if (t0 > t1) return kInfinity;
    }
    return t0;
}

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<Eigen::Vector3d>& vertices,
                         const std::vector<Eigen::Vector3i>& triangles) {
    triangles_.reserve(triangles.size());
    for (const Eigen::Vector3i& t : triangles) {
        const Eigen::Vector3d& v0 = vertices[t[0]];
        triangles_.push_back({v0, vertices[t[1]] - v0, vertices[t[2]] - v0});
    }
    nodes_.reserve(2 * triangles_.size() + 1);
    Build(0, static_cast<int>(triangles_.size()));
}

int TriangleBvh::Build(int first, int count) {
    const int index = static_cast<int>(nodes_.size());
    nodes_.emplace_back();
    Eigen::AlignedBox3d box;
    for (int i = first; i < first + count; ++i) {
        const Triangle& t = triangles_[i];
        box.extend(t.v0).extend(t.v0 + t.e1).extend(t.v0 + t.e2);
    }
    nodes_[index].box = box;
    if (count <= kLeafSize) {
        nodes_[index].first = first;
        nodes_[index].count = count;
        return index;
    }
    // Median split of the centroids along the longest box axis.
    int axis = 0;
    box.sizes().maxCoeff(&axis);
    const auto centroid = [axis](const Triangle& t) {
        return 3.0 * t.v0[axis] + t.e1[axis] + t.e2[axis];
    };
    const auto begin = triangles_.begin() + first;
    std::nth_element(
        begin, begin + count / 2, begin + count,
        [&](const Triangle& a, const Triangle& b) { return centroid(a) < centroid(b); });
    const int left = Build(first, count / 2);
    const int right = Build(first + count / 2, count - count / 2);
    nodes_[index].first = left;
    nodes_[index].right = right;
    return index;
}

std::optional<double> TriangleBvh::Intersect(const Eigen::Vector3d& origin,
                                             const Eigen::Vector3d& direction,
                                             double max_range) const {
    double best = max_range;
    if (FirstHit(origin, direction, &best) < 0) return std::nullopt;
    return best;
}

std::optional<TriangleHit> TriangleBvh::IntersectHit(const Eigen::Vector3d& origin,
                                                     const Eigen::Vector3d& direction,
                                                     double max_range) const {
    double best = max_range;
    const int index = FirstHit(origin, direction, &best);
    if (index < 0) return std::nullopt;
    const Triangle& tri = triangles_[index];
    return TriangleHit{best, tri.e1.cross(tri.e2).normalized()};
}

int TriangleBvh::FirstHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                          double* best) const {
    if (triangles_.empty()) return -1;
    const Eigen::Vector3d inv_direction = direction.cwiseInverse();
    int hit = -1;
    int stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = nodes_[stack[--top]];
        if (HitBox(node.box, origin, inv_direction, *best) > *best) continue;  // best shrank
        if (node.count > 0) {
            for (int i = node.first; i < node.first + node.count; ++i) {
                const double t = HitTriangle(triangles_[i], origin, direction);
                if (t > 1e-9 && t < *best) {
                    *best = t;
                    hit = i;
                }
            }
            continue;
        }
        // Visit the nearer child first.
        const double t_left = HitBox(nodes_[node.first].box, origin, inv_direction, *best);
        const double t_right = HitBox(nodes_[node.right].box, origin, inv_direction, *best);
        const bool left_first = t_left <= t_right;
        const int near_child = left_first ? node.first : node.right;
        const int far_child = left_first ? node.right : node.first;
        if (std::min(t_left, t_right) < kInfinity) {
            if (std::max(t_left, t_right) < kInfinity) stack[top++] = far_child;
            stack[top++] = near_child;
        }
    }
    return hit;
}

}  // namespace soilvol
