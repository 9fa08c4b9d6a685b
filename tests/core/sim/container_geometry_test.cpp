#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

#include "core/common/angles.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/scene_raycaster.hpp"
#include "core/sim/soil_surface.hpp"
#include "tests/core/sim/inner_surface_integral.hpp"

namespace soilvol::sim {
namespace {

const ContainerKind kAllKinds[] = {ContainerKind::kPaperBucket, ContainerKind::kExcavatorBucket,
                                   ContainerKind::kTruckBed};

TEST(ContainerGeometryTest, PaperBucketHasThePapersCapacity) {
    const ContainerGeometry c = MakeContainer(ContainerKind::kPaperBucket);
    EXPECT_NEAR(c.struck_capacity_m3, 2.05 * 0.54 * 0.6, 1e-6);
    EXPECT_NEAR(c.struck_capacity_m3, 0.6642, 1e-6);
    EXPECT_NEAR(c.depth_m, 0.6, 1e-12);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(0.0, 0.0), -0.6);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(1.02, -0.265), -0.6);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(1.03, 0.0), 0.0);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(0.0, 0.28), 0.0);
}

TEST(ContainerGeometryTest, TruckBedHasItsBoxCapacity) {
    const ContainerGeometry c = MakeContainer(ContainerKind::kTruckBed);
    EXPECT_NEAR(c.struck_capacity_m3, 4.0 * 2.2 * 0.8, 1e-9);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(-1.9, 1.0), -0.8);
}

TEST(ContainerGeometryTest, ExcavatorCapacityIsTheIntegralOfItsProfile) {
    const ContainerGeometry c = MakeContainer(ContainerKind::kExcavatorBucket);
    EXPECT_NEAR(c.opening_length_m, 1.2, 1e-12);
    EXPECT_NEAR(c.opening_width_m, 1.0, 1e-12);
    EXPECT_NEAR(c.depth_m, 0.75, 1e-12);
    // Flat floor of 0.45 m, no overhangs.
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(0.3, -0.29), -0.75);
    EXPECT_DOUBLE_EQ(c.InnerSurfaceZ(-0.3, 0.14), -0.75);
    for (size_t i = 1; i < c.inner_profile_yz.size(); ++i) {
        EXPECT_GE(c.inner_profile_yz[i].x(), c.inner_profile_yz[i - 1].x());
    }
    const double integral = IntegrateInnerSurface(c, 0.0005);
    EXPECT_NEAR(integral, c.struck_capacity_m3, 1e-6 * c.struck_capacity_m3);
    // Trapezoid + quarter ellipse bound the chorded profile.
    const double ellipse = 1.2 * (0.5 * (0.45 + 0.65) * 0.75 + 0.25 * kPi * 0.35 * 0.75);
    EXPECT_LT(c.struck_capacity_m3, ellipse);
    EXPECT_GT(c.struck_capacity_m3, 0.98 * ellipse);
}

TEST(ContainerGeometryTest, HeapMatchesRectangleFormula) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        const double l = c.opening_length_m;
        const double w = c.opening_width_m;
        const int cols = 4000;
        const int rows = 2000;
        double integral = 0.0;
        for (int j = 0; j < rows; ++j) {
            for (int i = 0; i < cols; ++i) {
                const double x = -0.5 * l + (i + 0.5) * l / cols;
                const double y = -0.5 * w + (j + 0.5) * w / rows;
                integral += std::min(0.5 * l - std::abs(x), 0.5 * w - std::abs(y));
            }
        }
        integral *= l * w / (cols * rows);
        const double formula = w * w * l / 4.0 - w * w * w / 12.0;
        EXPECT_NEAR(integral, formula, 1e-6 * formula) << c.name;
        EXPECT_NEAR(HeapedCapacity(c, 1.0), c.struck_capacity_m3 + formula, 1e-12) << c.name;
        EXPECT_NEAR(HeapedCapacity(c, 0.5), c.struck_capacity_m3 + 0.5 * formula, 1e-12);
    }
}

TEST(ContainerGeometryTest, CornersAreCounterClockwiseInTheOpeningPlane) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        const Corners& k = c.opening_corners;
        EXPECT_GT((k[1] - k[0]).x(), 0.0);
        EXPECT_NEAR((k[1] - k[0]).norm(), c.opening_length_m, 1e-12);
        EXPECT_NEAR((k[2] - k[1]).norm(), c.opening_width_m, 1e-12);
        EXPECT_GT((k[1] - k[0]).cross(k[2] - k[1]).z(), 0.0);
        EXPECT_NEAR((k[0] + k[1] + k[2] + k[3]).norm(), 0.0, 1e-12);
        for (const Eigen::Vector3d& corner : k) EXPECT_EQ(corner.z(), 0.0);
    }
}

TEST(ContainerGeometryTest, MeshPartsAreClosedAndConsistentlyOriented) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        std::map<std::pair<int, int>, int> edges;
        for (const Eigen::Vector3i& t : c.triangles) {
            for (int e = 0; e < 3; ++e) ++edges[{t[e], t[(e + 1) % 3]}];
        }
        for (const auto& [edge, count] : edges) {
            ASSERT_EQ(count, 1) << c.name;
            ASSERT_EQ(edges.count({edge.second, edge.first}), 1u) << c.name;
        }
    }
}

TEST(ContainerGeometryTest, MeshLeavesTheCavityEmpty) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        const double tol = 1e-3;
        for (const Eigen::Vector3i& t : c.triangles) {
            for (int a = 0; a <= 10; ++a) {
                for (int b = 0; a + b <= 10; ++b) {
                    const Eigen::Vector3d p = c.vertices[t[0]] +
                                              0.1 * a * (c.vertices[t[1]] - c.vertices[t[0]]) +
                                              0.1 * b * (c.vertices[t[2]] - c.vertices[t[0]]);
                    const bool inside = std::abs(p.x()) < 0.5 * c.opening_length_m - tol &&
                                        std::abs(p.y()) < 0.5 * c.opening_width_m - tol &&
                                        p.z() < -tol && p.z() > c.InnerSurfaceZ(p.x(), p.y()) + tol;
                    ASSERT_FALSE(inside) << c.name << " " << p.transpose();
                }
            }
        }
    }
}

TEST(ContainerGeometryTest, OutsideHasNoMirrorOrTurnSymmetry) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        for (const Eigen::Vector3d& flip :
             {Eigen::Vector3d(-1, 1, 1), Eigen::Vector3d(1, -1, 1), Eigen::Vector3d(-1, -1, 1)}) {
            int unmatched = 0;
            for (const Eigen::Vector3d& v : c.vertices) {
                const Eigen::Vector3d image = flip.cwiseProduct(v);
                bool found = false;
                for (const Eigen::Vector3d& w : c.vertices) found |= (w - image).norm() < 1e-3;
                unmatched += found ? 0 : 1;
            }
            EXPECT_GT(unmatched, 4) << c.name << " flip " << flip.transpose();
        }
    }
}

TEST(ContainerGeometryTest, RimTopIsTheOpeningPlane) {
    for (const ContainerKind kind : kAllKinds) {
        const ContainerGeometry c = MakeContainer(kind);
        const SceneRaycaster raycaster(c, SoilSurface(c, SoilSpec{}, 1));
        const double hx = 0.5 * c.opening_length_m;
        const double hy = 0.5 * c.opening_width_m;
        const Eigen::Vector3d down(0.0, 0.0, -1.0);
        // Edge normals with the half extent along them, probed 1 cm outside and inside.
        const std::pair<Eigen::Vector2d, double> edges[] = {
            {{0.0, 1.0}, hy}, {{0.0, -1.0}, hy}, {{1.0, 0.0}, hx}, {{-1.0, 0.0}, hx}};
        for (const auto& [normal, half] : edges) {
            const Eigen::Vector2d rim = (half + 0.01) * normal;
            const auto hit = raycaster.Cast({rim.x(), rim.y(), 1.0}, down, 10.0);
            ASSERT_TRUE(hit.has_value()) << c.name;
            EXPECT_NEAR(*hit, 1.0, 1e-9) << c.name << " at " << rim.transpose();
            const Eigen::Vector2d inside = (half - 0.01) * normal;
            const auto floor = raycaster.Cast({inside.x(), inside.y(), 1.0}, down, 10.0);
            ASSERT_TRUE(floor.has_value());
            EXPECT_NEAR(*floor, 1.0 - c.InnerSurfaceZ(inside.x(), inside.y()), 1e-9) << c.name;
        }
    }
}

}  // namespace
}  // namespace soilvol::sim
