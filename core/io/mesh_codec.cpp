#include "core/io/mesh_codec.hpp"

#include <algorithm>

#include "absl/status/status.h"
#include "core/io/mesh_decoder.hpp"

namespace soilvol::io {
namespace {

bool LooksLikePly(std::string_view bytes) {
    return bytes.substr(0, 4) == "ply\n" || bytes.substr(0, 5) == "ply\r\n";
}

// A control byte other than whitespace in the header, count or first facet: not text. A binary
// STL nearly always has one (a count below 2^24 has a zero byte).
bool LooksBinary(std::string_view bytes) {
    const std::string_view head = bytes.substr(0, detail::kStlHeaderBytes + detail::kStlFacetBytes);
    return std::any_of(head.begin(), head.end(), [](char c) {
        const auto byte = static_cast<unsigned char>(c);
        return (byte < 0x20 && std::string_view("\t\n\v\f\r").find(c) == std::string_view::npos) ||
               byte == 0x7f;
    });
}

}  // namespace

absl::StatusOr<DecodedMesh> DecodeMesh(std::string_view bytes, const MeshBudget& budget) {
    if (bytes.empty()) return absl::InvalidArgumentError("mesh data is empty (0 bytes)");
    // Many binary STL headers start with "solid" too: the size rule goes first.
    if (detail::HasBinaryStlSize(bytes)) return detail::DecodeStlBinary(bytes, budget);
    if (LooksLikePly(bytes)) return detail::DecodePlyMesh(bytes, budget);
    if (detail::LooksLikeAsciiStl(bytes)) return detail::DecodeStlAscii(bytes, budget);
    if (detail::LooksLikeObj(bytes)) return detail::DecodeObj(bytes, budget);
    // Binary of the wrong size: truncated, or a count beyond the bytes present.
    if (LooksBinary(bytes)) return detail::DecodeStlBinary(bytes, budget);
    return absl::InvalidArgumentError(
        "unrecognised mesh format (expected binary or ASCII STL, OBJ, or PLY with faces)");
}

}  // namespace soilvol::io
