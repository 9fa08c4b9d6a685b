#include <array>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/io/mesh_decoder.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {
namespace {

// Whitespace-separated tokens across lines, counting lines for messages.
class TokenStream {
  public:
    explicit TokenStream(std::string_view text) : lines_(text) {}

    bool Next(std::string_view* token) {
        while (!tokens_.Next(token)) {
            std::string_view line;
            if (!lines_.Next(&line)) return false;
            ++line_;
            tokens_ = TokenReader(line);
        }
        return true;
    }
    void SkipRestOfLine() { tokens_ = TokenReader(std::string_view()); }
    std::size_t line() const { return line_; }

  private:
    LineReader lines_;
    TokenReader tokens_{std::string_view()};
    std::size_t line_ = 0;
};

absl::Status StlError(const TokenStream& tokens, absl::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("ASCII STL line ", tokens.line(), ": ", what));
}

absl::Status Expect(TokenStream* tokens, const char* keyword) {
    std::string_view token;
    if (!tokens->Next(&token)) {
        return StlError(*tokens, absl::StrCat("input ends where '", keyword, "' belongs"));
    }
    if (token == keyword) return absl::OkStatus();
    return StlError(*tokens,
                    absl::StrCat("expected '", keyword, "', found '", Printable(token), "'"));
}

absl::Status ReadXyz(TokenStream* tokens, const char* what, Eigen::Vector3f* xyz) {
    std::string_view token;
    for (int axis = 0; axis < 3; ++axis) {
        if (!tokens->Next(&token)) return StlError(*tokens, absl::StrCat("input ends in ", what));
        if (!ParseCoordinate(token, /*as_double=*/false, &(*xyz)[axis])) {
            return StlError(*tokens,
                            absl::StrCat("'", Printable(token), "' is not a number (", what, ")"));
        }
    }
    return absl::OkStatus();
}

// After "facet": normal (read, then ignored), outer loop, three vertices, endloop, endfacet.
absl::Status ReadFacet(TokenStream* tokens, MeshBuilder* mesh) {
    Eigen::Vector3f normal;
    std::array<Eigen::Vector3f, 3> corners;
    SOILVOL_RETURN_IF_ERROR(Expect(tokens, "normal"));
    SOILVOL_RETURN_IF_ERROR(ReadXyz(tokens, "a normal", &normal));
    SOILVOL_RETURN_IF_ERROR(Expect(tokens, "outer"));
    SOILVOL_RETURN_IF_ERROR(Expect(tokens, "loop"));
    for (Eigen::Vector3f& corner : corners) {
        SOILVOL_RETURN_IF_ERROR(Expect(tokens, "vertex"));
        SOILVOL_RETURN_IF_ERROR(ReadXyz(tokens, "a vertex", &corner));
    }
    SOILVOL_RETURN_IF_ERROR(Expect(tokens, "endloop"));
    SOILVOL_RETURN_IF_ERROR(Expect(tokens, "endfacet"));
    const absl::Status added = mesh->AddFacet(corners);
    return added.ok() ? added : StlError(*tokens, added.message());
}

}  // namespace

bool LooksLikeAsciiStl(std::string_view bytes) {
    TokenStream tokens(bytes.substr(0, kMaxHeaderBytes));
    std::string_view token;
    if (!tokens.Next(&token) || token != "solid") return false;
    tokens.SkipRestOfLine();  // the solid's name
    return tokens.Next(&token) && (token == "facet" || token == "endsolid");
}

absl::StatusOr<DecodedMesh> DecodeStlAscii(std::string_view bytes, const MeshBudget& budget) {
    TokenStream tokens(bytes);
    MeshBuilder mesh(MeshFormat::kStlAscii, budget);
    SOILVOL_RETURN_IF_ERROR(Expect(&tokens, "solid"));
    tokens.SkipRestOfLine();
    std::string_view token;
    while (true) {
        if (!tokens.Next(&token)) return StlError(tokens, "input ends before 'endsolid'");
        if (token == "facet") {
            SOILVOL_RETURN_IF_ERROR(ReadFacet(&tokens, &mesh));
            continue;
        }
        if (token != "endsolid") {
            return StlError(tokens, absl::StrCat("expected 'facet' or 'endsolid', found '",
                                                 Printable(token), "'"));
        }
        tokens.SkipRestOfLine();
        // Another solid may follow; anything else may not.
        if (!tokens.Next(&token)) break;
        if (token != "solid") {
            return StlError(tokens, absl::StrCat("'", Printable(token), "' after 'endsolid'"));
        }
        tokens.SkipRestOfLine();
    }
    return std::move(mesh).Finish();
}

}  // namespace soilvol::io::detail
