// libFuzzer: the mesh decoder (binary/ASCII STL, OBJ, PLY in 3 encodings) on any bytes, with a
// small budget so that budget checks are reached. An accepted mesh must be within the budget,
// hold finite vertices and in-range indices, and decode again from its STL encoding (binary and
// ASCII) to as many triangles.
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "core/io/mesh_codec.hpp"

namespace {

using soilvol::io::DecodedMesh;
using soilvol::io::DecodeMesh;
using soilvol::io::MeshBudget;

void CheckInvariants(const DecodedMesh& mesh, const MeshBudget& budget) {
    if (mesh.triangles.empty() || mesh.triangles.size() > budget.max_triangles) std::abort();
    if (mesh.vertices.size() > budget.max_vertices) std::abort();
    for (const auto& v : mesh.vertices) {
        if (!v.allFinite()) std::abort();
    }
    const auto count = static_cast<int>(mesh.vertices.size());
    for (const auto& t : mesh.triangles) {
        if (t.minCoeff() < 0 || t.maxCoeff() >= count) std::abort();
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) std::abort();
    }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    MeshBudget budget;
    budget.max_triangles = 20'000;
    budget.max_vertices = 20'000;
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    const auto mesh = DecodeMesh(bytes, budget);
    if (!mesh.ok()) return 0;
    CheckInvariants(*mesh, budget);
    for (const bool binary : {true, false}) {
        const auto again = DecodeMesh(soilvol::io::EncodeStl(*mesh, binary), budget);
        if (!again.ok() || again->triangles.size() != mesh->triangles.size()) std::abort();
        CheckInvariants(*again, budget);
    }
    return 0;
}
