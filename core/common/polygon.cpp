#include "core/common/polygon.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace soilvol {
namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() * b.y() - a.y() * b.x();
}

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
    const Eigen::Vector2d ab = b - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    return (a + t * ab - p).norm();
}

bool SegmentsIntersect(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d) {
    const double d1 = Cross(b - a, c - a), d2 = Cross(b - a, d - a);
    const double d3 = Cross(d - c, a - c), d4 = Cross(d - c, b - c);
    return ((d1 > 0) != (d2 > 0)) && ((d3 > 0) != (d4 > 0));
}

// Sutherland-Hodgman against one side of an axis-aligned box: keeps sign * (p[axis] - bound) <= 0.
// Exact for the area of concave polygons too (the clip region is convex).
std::vector<Eigen::Vector2d> ClipHalfPlane(const std::vector<Eigen::Vector2d>& in, int axis,
                                           double bound, double sign) {
    std::vector<Eigen::Vector2d> out;
    const std::size_t n = in.size();
    for (std::size_t i = 0; i < n; ++i) {
        const Eigen::Vector2d& cur = in[i];
        const Eigen::Vector2d& nxt = in[(i + 1) % n];
        const double dc = sign * (cur[axis] - bound);
        const double dn = sign * (nxt[axis] - bound);
        if (dc <= 0.0) out.push_back(cur);
        if ((dc <= 0.0) != (dn <= 0.0)) out.push_back(cur + (nxt - cur) * (dc / (dc - dn)));
    }
    return out;
}

}  // namespace

double SignedArea(const std::vector<Eigen::Vector2d>& vertices) {
    double twice = 0.0;
    for (std::size_t i = 0; i < vertices.size(); ++i) {
        twice += Cross(vertices[i], vertices[(i + 1) % vertices.size()]);
    }
    return 0.5 * twice;
}

Polygon2d::Polygon2d(std::vector<Eigen::Vector2d> vertices) : vertices_(std::move(vertices)) {
    if (SignedArea(vertices_) < 0.0) std::reverse(vertices_.begin(), vertices_.end());
}

double Polygon2d::Area() const { return std::abs(SignedArea(vertices_)); }

bool Polygon2d::Contains(const Eigen::Vector2d& p) const {
    bool inside = false;
    for (std::size_t i = 0, j = vertices_.size() - 1; i < vertices_.size(); j = i++) {
        const Eigen::Vector2d& a = vertices_[i];
        const Eigen::Vector2d& b = vertices_[j];
        if ((a.y() > p.y()) != (b.y() > p.y()) &&
            p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
            inside = !inside;
        }
    }
    return inside;
}

double Polygon2d::ClippedArea(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) const {
    return Clip(lo, hi).first;
}

std::pair<double, Eigen::Vector2d> Polygon2d::Clip(const Eigen::Vector2d& lo,
                                                   const Eigen::Vector2d& hi) const {
    std::vector<Eigen::Vector2d> poly = ClipHalfPlane(vertices_, 0, hi.x(), 1.0);
    poly = ClipHalfPlane(poly, 0, lo.x(), -1.0);
    poly = ClipHalfPlane(poly, 1, hi.y(), 1.0);
    poly = ClipHalfPlane(poly, 1, lo.y(), -1.0);
    const Eigen::Vector2d centre = 0.5 * (lo + hi);
    if (poly.size() < 3) return {0.0, centre};
    double twice = 0.0;
    Eigen::Vector2d weighted = Eigen::Vector2d::Zero();
    for (std::size_t i = 0; i < poly.size(); ++i) {
        const Eigen::Vector2d& a = poly[i];
        const Eigen::Vector2d& b = poly[(i + 1) % poly.size()];
        const double cross = Cross(a, b);
        twice += cross;
        weighted += (a + b) * cross;
    }
    if (std::abs(twice) < 1e-18) return {0.0, centre};
    return {std::abs(0.5 * twice), weighted / (3.0 * twice)};
}

double Polygon2d::DistanceToBoundary(const Eigen::Vector2d& p) const {
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < vertices_.size(); ++i) {
        best =
            std::min(best, SegmentDistance(p, vertices_[i], vertices_[(i + 1) % vertices_.size()]));
    }
    return best;
}

Eigen::Vector2d Polygon2d::Min() const {
    Eigen::Vector2d lo = vertices_.front();
    for (const auto& v : vertices_) lo = lo.cwiseMin(v);
    return lo;
}

Eigen::Vector2d Polygon2d::Max() const {
    Eigen::Vector2d hi = vertices_.front();
    for (const auto& v : vertices_) hi = hi.cwiseMax(v);
    return hi;
}

bool Polygon2d::IsSimple() const {
    const std::size_t n = vertices_.size();
    for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t j = i + 2; j < n; ++j) {
            if (i == 0 && j == n - 1) continue;  // adjacent through the closing edge
            if (SegmentsIntersect(vertices_[i], vertices_[(i + 1) % n], vertices_[j],
                                  vertices_[(j + 1) % n])) {
                return false;
            }
        }
    }
    return true;
}

double Polygon2d::DistanceIntegral(int samples_per_axis) const {
    const Eigen::Vector2d lo = Min(), hi = Max();
    const Eigen::Vector2d step = (hi - lo) / samples_per_axis;
    double sum = 0.0;
    for (int i = 0; i < samples_per_axis; ++i) {
        for (int j = 0; j < samples_per_axis; ++j) {
            const Eigen::Vector2d p =
                lo + Eigen::Vector2d((i + 0.5) * step.x(), (j + 0.5) * step.y());
            if (Contains(p)) sum += DistanceToBoundary(p);
        }
    }
    return sum * step.x() * step.y();
}

}  // namespace soilvol
