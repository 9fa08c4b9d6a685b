#include "server/handlers/mesh_request.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

/// A closed box 2 x 1 x 1 m as binary STL.
std::string BoxStl() {
    io::DecodedMesh box;
    for (int i = 0; i < 8; ++i) box.vertices.emplace_back(2.0 * (i & 1), (i >> 1) & 1, i >> 2);
    const int faces[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                              {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
    for (const auto& f : faces) box.triangles.emplace_back(f[0], f[1], f[2]);
    return io::EncodeStl(box);
}

v1::MeshScan MeshAlone() {
    v1::MeshScan mesh;
    mesh.set_data(BoxStl());
    for (const auto& [x, y] : {std::pair{0.0, 0.0}, {2.0, 0.0}, {2.0, 1.0}, {0.0, 1.0}}) {
        v1::Point3* corner = mesh.add_corners();
        corner->set_x(x);
        corner->set_y(y);
        corner->set_z(1.0);
    }
    mesh.mutable_container_pose()->mutable_position_m()->set_z(-3.0);
    mesh.set_range_noise_m(0.01);
    return mesh;
}

TEST(MeshBudgetFor, ADenseBinaryPlyOfTheMessageAtMostTheCoreDefault) {
    const io::MeshBudget small = MeshBudgetFor(std::size_t{1} << 20);
    EXPECT_EQ(small.max_triangles, (std::size_t{1} << 20) / 13);
    EXPECT_EQ(small.max_vertices, (std::size_t{1} << 20) / 12);
    const io::MeshBudget large = MeshBudgetFor(std::size_t{1024} << 20);
    EXPECT_EQ(large.max_triangles, io::MeshBudget{}.max_triangles);
    EXPECT_EQ(large.max_vertices, io::MeshBudget{}.max_vertices);
}

TEST(ToMeshRequest, MeshAloneCarriesItsPlacement) {
    const absl::StatusOr<MeshRequest> mesh = ToMeshRequest(MeshAlone(), false, {});
    ASSERT_TRUE(mesh.ok()) << mesh.status();
    EXPECT_EQ(mesh->input.mesh.triangles.size(), 12u);
    EXPECT_EQ(mesh->input.mesh.vertices.size(), 8u);
    EXPECT_EQ(mesh->input.corners[2], Eigen::Vector3d(2.0, 1.0, 1.0));
    ASSERT_TRUE(mesh->T_scan_mesh.has_value());
    EXPECT_DOUBLE_EQ(mesh->T_scan_mesh->translation().z(), -3.0);
    EXPECT_DOUBLE_EQ(mesh->range_noise_m, 0.01);
}

TEST(ToMeshRequest, BesideAScanThePlacementIsTheScans) {
    v1::MeshScan mesh = MeshAlone();
    mesh.clear_container_pose();
    mesh.clear_range_noise_m();
    const absl::StatusOr<MeshRequest> request = ToMeshRequest(mesh, true, {});
    ASSERT_TRUE(request.ok()) << request.status();
    EXPECT_FALSE(request->T_scan_mesh.has_value());
}

TEST(ToMeshRequest, HostileRequestsNameTheField) {
    struct Case {
        const char* field;
        bool with_scan;
        void (*mutate)(v1::MeshScan&);
    };
    const Case cases[] = {
        {"mesh.corners", false, [](v1::MeshScan& m) { m.mutable_corners()->RemoveLast(); }},
        {"mesh.corners[1]", false,
         [](v1::MeshScan& m) { m.mutable_corners(1)->set_y(std::nan("")); }},
        {"mesh.container_pose", false, [](v1::MeshScan& m) { m.clear_container_pose(); }},
        {"mesh.container_pose", true, [](v1::MeshScan&) {}},
        {"mesh.container_pose.orientation", false,
         [](v1::MeshScan& m) { m.mutable_container_pose()->mutable_orientation()->set_w(3.0); }},
        {"mesh.range_noise_m", false, [](v1::MeshScan& m) { m.clear_range_noise_m(); }},
        {"mesh.range_noise_m", true, [](v1::MeshScan& m) { m.clear_container_pose(); }},
        {"mesh.data", false, [](v1::MeshScan& m) { m.clear_data(); }},
        {"mesh.data", false, [](v1::MeshScan& m) { m.mutable_data()->resize(100); }},
        {"mesh.data", false, [](v1::MeshScan& m) { m.set_data("v 0 0 0\nf 1 1 7\n"); }},
    };
    for (const Case& c : cases) {
        v1::MeshScan mesh = MeshAlone();
        c.mutate(mesh);
        const absl::StatusOr<MeshRequest> request = ToMeshRequest(mesh, c.with_scan, {});
        EXPECT_TRUE(absl::IsInvalidArgument(request.status())) << c.field;
        EXPECT_EQ(FieldOf(request.status().message()), c.field) << request.status();
    }
}

TEST(ToMeshRequest, TheBudgetHoldsBeforeDecoding) {
    io::MeshBudget budget;
    budget.max_triangles = 11;
    const absl::StatusOr<MeshRequest> request = ToMeshRequest(MeshAlone(), false, budget);
    EXPECT_TRUE(absl::IsInvalidArgument(request.status()));
    EXPECT_EQ(FieldOf(request.status().message()), "mesh.data");
    EXPECT_NE(request.status().message().find("budget of 11"), std::string::npos)
        << request.status();
}

TEST(MeshStatus, CoreFieldsBecomeTheRequests) {
    const std::pair<absl::Status, std::string> cases[] = {
        {absl::InvalidArgumentError("range_noise_m: must lie in [0.001, 0.5] m"),
         "mesh.range_noise_m: must lie in [0.001, 0.5] m"},
        {absl::InvalidArgumentError("container_pose: needed"), "mesh.container_pose: needed"},
        {absl::InvalidArgumentError("mesh.opening: differs"), "mesh.corners: differs"},
        {absl::InvalidArgumentError("opening corners are collinear"),
         "mesh.corners: opening corners are collinear"},
        {absl::InvalidArgumentError("mesh: the sensor sees none of it"),
         "mesh: the sensor sees none of it"},
        {absl::FailedPreconditionError("too few points inside"), "too few points inside"},
    };
    for (const auto& [status, message] : cases) {
        const absl::Status mapped = MeshStatus(status, false);
        EXPECT_EQ(mapped.code(), status.code());
        EXPECT_EQ(mapped.message(), message);
    }
    // Beside a scan an unnamed error is the scan's.
    EXPECT_EQ(
        MeshStatus(absl::InvalidArgumentError("opening corners are collinear"), true).message(),
        "opening corners are collinear");
}

}  // namespace
}  // namespace soilvol::server
