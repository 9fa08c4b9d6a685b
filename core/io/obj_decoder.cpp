#include <array>
#include <cstdint>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/mesh_decoder.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

// Statements that may come before the first `v` line (all but `v` and `f` are ignored).
bool IsObjStatement(std::string_view keyword) {
    static constexpr std::string_view kStatements[] = {"v", "vt", "vn", "vp", "f",      "l",
                                                       "p", "o",  "g",  "s",  "mtllib", "usemtl"};
    for (const std::string_view statement : kStatements) {
        if (keyword == statement) return true;
    }
    return false;
}

absl::Status ParseVertex(TokenReader* tokens, MeshBuilder* mesh) {
    std::array<float, 3> xyz{};
    std::string_view token;
    for (float& value : xyz) {
        if (!tokens->Next(&token)) return absl::InvalidArgumentError("a vertex needs x, y and z");
        if (!ParseCoordinate(token, /*as_double=*/false, &value)) {
            return absl::InvalidArgumentError(
                absl::StrCat("'", Printable(token), "' is not a number"));
        }
    }
    return mesh->AddVertex(xyz[0], xyz[1], xyz[2]);  // w or a colour may follow: ignored
}

// A corner "i", "i/t", "i//n" or "i/t/n" as a 0-based index: OBJ counts from 1, and a negative
// index counts back from the last vertex read so far.
absl::StatusOr<std::uint64_t> ResolveCorner(std::string_view token, std::size_t vertices_so_far) {
    const std::string_view number = token.substr(0, token.find('/'));
    const bool relative = !number.empty() && number[0] == '-';
    std::uint64_t value = 0;
    if (!ParseUint64(relative ? number.substr(1) : number, &value)) {
        return absl::InvalidArgumentError(
            absl::StrCat("'", Printable(token), "' is not a vertex reference"));
    }
    if (value == 0) return absl::InvalidArgumentError("vertex index 0 (OBJ counts from 1)");
    if (!relative) return value - 1;
    if (value > vertices_so_far) {
        return absl::InvalidArgumentError(absl::StrCat("relative index -", value,
                                                       " reaches before ", "the first vertex (",
                                                       vertices_so_far, " read so far)"));
    }
    return vertices_so_far - value;
}

absl::Status ParseFace(TokenReader* tokens, MeshBuilder* mesh) {
    mesh->BeginFace();
    std::string_view token;
    while (tokens->Next(&token) && token[0] != '#') {
        SOILVOL_ASSIGN_OR_RETURN(const std::uint64_t index,
                                 ResolveCorner(token, mesh->vertex_count()));
        SOILVOL_RETURN_IF_ERROR(mesh->AddCorner(index));
    }
    return mesh->EndFace();
}

}  // namespace

bool LooksLikeObj(std::string_view bytes) {
    LineReader lines(bytes, kMaxHeaderBytes);
    std::string_view line;
    while (lines.NextNonBlank(&line)) {
        std::string_view keyword;
        TokenReader(line).Next(&keyword);
        if (keyword == "v") return true;
        if (keyword[0] != '#' && !IsObjStatement(keyword)) return false;
    }
    return false;
}

absl::StatusOr<DecodedMesh> DecodeObj(std::string_view bytes, const MeshBudget& budget) {
    MeshBuilder mesh(MeshFormat::kObj, budget);
    LineReader lines(bytes);
    std::string_view line;
    for (std::size_t number = 1; lines.Next(&line); ++number) {
        TokenReader tokens(line);
        std::string_view keyword;
        if (!tokens.Next(&keyword)) continue;
        absl::Status status;
        if (keyword == "v") {
            status = ParseVertex(&tokens, &mesh);
        } else if (keyword == "f") {
            status = ParseFace(&tokens, &mesh);
        }
        if (!status.ok()) {
            return absl::InvalidArgumentError(
                absl::StrCat("OBJ line ", number, ": ", status.message()));
        }
    }
    return std::move(mesh).Finish();
}

}  // namespace soilvol::io::detail
