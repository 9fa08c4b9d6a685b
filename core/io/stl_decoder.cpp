#include <array>
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/mesh_decoder.hpp"
#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {
namespace {

constexpr bool kSwap = !kHostIsLittleEndian;  // binary STL is little-endian

absl::Status StlError(absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("binary STL: ", what));
}

std::uint32_t DeclaredFacets(std::string_view bytes) {
    return LoadUnsigned<std::uint32_t>(bytes.data() + kStlHeaderBytes - 4, kSwap);
}

// 84 + 50 * count: fewer than 2^32 facets, so no overflow in 64 bits.
std::uint64_t ExpectedSize(std::uint32_t facets) {
    return kStlHeaderBytes + std::uint64_t{kStlFacetBytes} * facets;
}

}  // namespace

bool HasBinaryStlSize(std::string_view bytes) {
    return bytes.size() >= kStlHeaderBytes && ExpectedSize(DeclaredFacets(bytes)) == bytes.size();
}

absl::StatusOr<DecodedMesh> DecodeStlBinary(std::string_view bytes, const MeshBudget& budget) {
    if (bytes.size() < kStlHeaderBytes) {
        return StlError(absl::StrCat(bytes.size(), " bytes is shorter than the 84-byte header"));
    }
    const std::uint32_t facets = DeclaredFacets(bytes);
    const std::uint64_t expected = ExpectedSize(facets);
    if (expected != bytes.size()) {
        return StlError(absl::StrCat("the header declares ", facets, " triangles (", expected,
                                     " bytes) but the input has ", bytes.size(), " bytes",
                                     expected > bytes.size() ? " (truncated)" : ""));
    }
    if (facets > budget.max_triangles) {
        return StlError(
            absl::StrCat(facets, " triangles is more than the budget of ", budget.max_triangles));
    }
    MeshBuilder mesh(MeshFormat::kStlBinary, budget);
    mesh.Reserve(facets / 2 + 2, facets);  // a closed mesh has about half as many vertices
    std::array<Eigen::Vector3f, 3> corners;
    for (std::uint32_t i = 0; i < facets; ++i) {
        // Each facet: normal (ignored), 3 corners, a 2-byte attribute (ignored).
        const char* p = bytes.data() + kStlHeaderBytes + std::size_t{kStlFacetBytes} * i + 12;
        for (Eigen::Vector3f& corner : corners) {
            for (int axis = 0; axis < 3; ++axis, p += 4) {
                corner[axis] = LoadCoordinate(p, ScalarType::kFloat32, kSwap);
            }
        }
        SOILVOL_RETURN_IF_ERROR(mesh.AddFacet(corners));
    }
    return std::move(mesh).Finish();
}

}  // namespace soilvol::io::detail
