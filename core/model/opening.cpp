#include "core/model/opening.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace soilvol::model {
namespace {

absl::Status CheckCorners(const Corners& corners, const OpeningConfig& config) {
    for (int i = 0; i < 4; ++i) {
        if (!corners[static_cast<std::size_t>(i)].allFinite()) {
            return absl::InvalidArgumentError(absl::StrCat("opening corner ", i, " is not finite"));
        }
    }
    for (int i = 0; i < 4; ++i) {
        const double edge =
            (corners[static_cast<std::size_t>((i + 1) % 4)] - corners[static_cast<std::size_t>(i)])
                .norm();
        if (edge < config.min_edge_m) {
            return absl::InvalidArgumentError(absl::StrFormat(
                "opening corners %d and %d are %.3f m apart (minimum %.3f m): coincident corners",
                i, (i + 1) % 4, edge, config.min_edge_m));
        }
        if (edge > config.max_edge_m) {
            return absl::InvalidArgumentError(absl::StrFormat(
                "opening.corners: corners %d and %d are %.1f m apart; openings up to %.0f m a "
                "side are served",
                i, (i + 1) % 4, edge, config.max_edge_m));
        }
    }
    // Shoelace area of the corners projected on their best plane is at most that of the
    // triangle fan in 3D: the fan bounds it without a plane fit.
    const Eigen::Vector3d fan = 0.5 * ((corners[1] - corners[0]).cross(corners[2] - corners[0]) +
                                       (corners[2] - corners[0]).cross(corners[3] - corners[0]));
    if (fan.norm() > config.max_area_m2) {
        return absl::InvalidArgumentError(
            absl::StrFormat("opening.corners: the opening spans %.0f m^2; openings up to %.0f m^2 "
                            "are served",
                            fan.norm(), config.max_area_m2));
    }
    return absl::OkStatus();
}

// Least-squares plane through the corners: centroid, eigenvalues (ascending) and eigenvectors.
struct CornerPlane {
    Eigen::Vector3d centroid;
    Eigen::Vector3d eigenvalues;
    Eigen::Matrix3d eigenvectors;
};

CornerPlane FitPlane(const Corners& corners) {
    CornerPlane plane;
    plane.centroid = Eigen::Vector3d::Zero();
    for (const auto& c : corners) plane.centroid += c / 4.0;
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& c : corners) cov += (c - plane.centroid) * (c - plane.centroid).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
    plane.eigenvalues = solver.eigenvalues();
    plane.eigenvectors = solver.eigenvectors();
    return plane;
}

absl::Status CheckShape(const std::vector<Eigen::Vector2d>& poly, double shortest_edge,
                        const OpeningConfig& config) {
    if (!Polygon2d(poly).IsSimple()) {
        return absl::InvalidArgumentError(
            "opening corners are not ordered around the opening: its edges cross");
    }
    const double area = std::abs(SignedArea(poly));
    if (area < 1e-3 * shortest_edge * shortest_edge) {
        return absl::InvalidArgumentError("opening corners are collinear");
    }
    for (int i = 0; i < 4; ++i) {
        const Eigen::Vector2d& prev = poly[static_cast<std::size_t>((i + 3) % 4)];
        const Eigen::Vector2d& cur = poly[static_cast<std::size_t>(i)];
        const Eigen::Vector2d& next = poly[static_cast<std::size_t>((i + 1) % 4)];
        const Eigen::Vector2d u = prev - cur, v = next - cur;
        const double tri = 0.5 * std::abs(u.x() * v.y() - u.y() * v.x());
        if (tri < config.min_corner_area_ratio * area) {
            return absl::InvalidArgumentError(
                absl::StrCat("opening corner ", i,
                             " lies on the line through its neighbours (collinear corners)"));
        }
    }
    return absl::OkStatus();
}

}  // namespace

namespace {

Cloud Transformed(const Cloud& points, const Pose& pose) {
    const Eigen::Matrix4f T = pose.matrix().cast<float>();
    const Eigen::Matrix3f R = T.topLeftCorner<3, 3>();
    const Eigen::Vector3f t = T.topRightCorner<3, 1>();
    Cloud out(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) out[i] = R * points[i] + t;
    return out;
}

}  // namespace

Cloud ToContainerFrame(const Cloud& points, const Pose& T_scan_container) {
    return Transformed(points, T_scan_container.inverse());
}

Cloud ToScanFrame(const Cloud& points, const Pose& T_scan_container) {
    return Transformed(points, T_scan_container);
}

absl::StatusOr<Opening> MakeOpening(const Corners& corners, const Cloud& empty_scan,
                                    const OpeningConfig& config) {
    if (auto status = CheckCorners(corners, config); !status.ok()) return status;
    double shortest = 1e300;
    for (int i = 0; i < 4; ++i) {
        shortest = std::min(shortest, (corners[static_cast<std::size_t>((i + 1) % 4)] -
                                       corners[static_cast<std::size_t>(i)])
                                          .norm());
    }
    const CornerPlane plane = FitPlane(corners);
    if (plane.eigenvalues(1) < 1e-6 * plane.eigenvalues(2)) {
        return absl::InvalidArgumentError("opening corners are collinear");
    }
    const Eigen::Vector3d normal = plane.eigenvectors.col(0);
    const Eigen::Vector3d& centroid = plane.centroid;
    Opening opening;
    for (const auto& c : corners) {
        opening.nonplanarity_m =
            std::max(opening.nonplanarity_m, std::abs((c - centroid).dot(normal)));
    }
    if (opening.nonplanarity_m > config.max_nonplanarity * shortest) {
        return absl::InvalidArgumentError(absl::StrFormat(
            "opening corners are far from planar: a corner is %.3f m off their plane (maximum "
            "%.3f m)",
            opening.nonplanarity_m, config.max_nonplanarity * shortest));
    }
    // Container frame: x along corner 0 -> 1 in the plane, z the normal.
    Eigen::Vector3d x = corners[1] - corners[0];
    x = (x - x.dot(normal) * normal).normalized();
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(1) = normal.cross(x);
    R.col(2) = normal;
    std::vector<Eigen::Vector2d> poly;
    for (const auto& c : corners) poly.push_back((R.transpose() * (c - centroid)).head<2>());
    if (auto status = CheckShape(poly, shortest, config); !status.ok()) return status;
    // The inside is where the empty scan's points over the opening lie: below the plane.
    const Polygon2d polygon(poly);
    std::vector<double> depth;
    for (const auto& p : empty_scan) {
        const Eigen::Vector3d q = R.transpose() * (p.cast<double>() - centroid);
        if (polygon.Contains(q.head<2>())) depth.push_back(q.z());
    }
    if (depth.empty()) {
        return absl::InvalidArgumentError("no point of the empty scan lies over the opening");
    }
    std::nth_element(depth.begin(), depth.begin() + static_cast<long>(depth.size() / 2),
                     depth.end());
    if (depth[depth.size() / 2] > 0.0) {
        R.col(1) = -R.col(1);
        R.col(2) = -R.col(2);
        for (auto& v : poly) v.y() = -v.y();
    }
    // Origin at the area centroid of the opening.
    const Polygon2d oriented(poly);
    Eigen::Vector2d area_centroid = Eigen::Vector2d::Zero();
    const auto& v = oriented.Vertices();
    double twice = 0.0;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const double cross =
            v[i].x() * v[(i + 1) % v.size()].y() - v[(i + 1) % v.size()].x() * v[i].y();
        area_centroid += (v[i] + v[(i + 1) % v.size()]) * cross;
        twice += cross;
    }
    area_centroid /= 3.0 * twice;
    for (auto& p : poly) p -= area_centroid;
    opening.T_scan_container.linear() = R;
    opening.T_scan_container.translation() = centroid + R.leftCols<2>() * area_centroid;
    opening.polygon = Polygon2d(poly);
    if (SignedArea(poly) < 0.0) opening.corner_of_vertex = {3, 2, 1, 0};
    opening.area_m2 = opening.polygon.Area();
    return opening;
}

bool EntersThroughOpening(const Eigen::Vector3d& sensor, const Eigen::Vector3f& p,
                          const Polygon2d& opening) {
    const double z = static_cast<double>(p.z());
    if (z >= 0.0 || sensor.z() <= 0.0) return true;
    const double t = sensor.z() / (sensor.z() - z);
    const Eigen::Vector3d crossing = sensor + t * (p.cast<double>() - sensor);
    return opening.Contains(crossing.head<2>());
}

Cloud ThroughOpening(Cloud points, const Eigen::Vector3d& sensor, const Polygon2d& opening) {
    points.erase(std::remove_if(points.begin(), points.end(),
                                [&](const Eigen::Vector3f& p) {
                                    return !EntersThroughOpening(sensor, p, opening);
                                }),
                 points.end());
    return points;
}

}  // namespace soilvol::model
