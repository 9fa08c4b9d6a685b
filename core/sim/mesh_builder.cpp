#include "core/sim/mesh_builder.hpp"

#include <algorithm>

namespace soilvol::sim {

MeshBuilder::MeshBuilder(std::vector<Eigen::Vector3d>* vertices,
                         std::vector<Eigen::Vector3i>* triangles)
    : vertices_(vertices), triangles_(triangles) {}

void MeshBuilder::AddPrism(const std::vector<Eigen::Vector3d>& polygon,
                           const Eigen::Vector3d& extrusion) {
    const int n = static_cast<int>(polygon.size());
    if (n < 3) return;
    // Wind the polygon so that its normal points against the extrusion (the bottom cap faces out).
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();
    for (int i = 0; i < n; ++i) normal += polygon[i].cross(polygon[(i + 1) % n]);
    std::vector<Eigen::Vector3d> bottom = polygon;
    if (normal.dot(extrusion) > 0.0) std::reverse(bottom.begin(), bottom.end());

    const int base = static_cast<int>(vertices_->size());
    for (const Eigen::Vector3d& p : bottom) vertices_->push_back(p);
    for (const Eigen::Vector3d& p : bottom) vertices_->push_back(p + extrusion);
    for (int i = 1; i + 1 < n; ++i) {
        triangles_->emplace_back(base, base + i, base + i + 1);
        triangles_->emplace_back(base + n, base + n + i + 1, base + n + i);
    }
    for (int i = 0; i < n; ++i) {
        const int j = (i + 1) % n;
        triangles_->emplace_back(base + i, base + n + i, base + n + j);
        triangles_->emplace_back(base + i, base + n + j, base + j);
    }
}

void MeshBuilder::AddPrismX(const std::vector<Eigen::Vector2d>& polygon_yz, double x0, double x1) {
    std::vector<Eigen::Vector3d> polygon;
    for (const Eigen::Vector2d& p : polygon_yz) polygon.emplace_back(x0, p.x(), p.y());
    AddPrism(polygon, Eigen::Vector3d(x1 - x0, 0.0, 0.0));
}

void MeshBuilder::AddBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
    AddOrientedBox(0.5 * (min + max), 0.5 * (max - min), Eigen::Matrix3d::Identity());
}

void MeshBuilder::AddOrientedBox(const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                                 const Eigen::Matrix3d& rotation) {
    const Eigen::Vector3d ax = rotation.col(0) * half.x();
    const Eigen::Vector3d ay = rotation.col(1) * half.y();
    const Eigen::Vector3d az = rotation.col(2) * half.z();
    const Eigen::Vector3d b = centre - az;
    AddPrism({b - ax - ay, b + ax - ay, b + ax + ay, b - ax + ay}, 2.0 * az);
}

}  // namespace soilvol::sim
