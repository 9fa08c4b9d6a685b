#include "server/store/entry_id.hpp"

#include <string>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

bool IsAlnum(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9');
}

bool IsIdChar(char c) { return IsAlnum(c) || c == '.' || c == '_' || c == '-'; }

// 'x' for a printable character, '\x00' style for anything else (NUL, UTF-8 bytes, controls).
std::string Quoted(char c) {
    return absl::StrCat("'", absl::CHexEscape(absl::string_view(&c, 1)), "'");
}

}  // namespace

absl::Status ValidateId(std::string_view id, std::string_view field) {
    constexpr absl::string_view kRule = " (allowed: [A-Za-z0-9][A-Za-z0-9._-]{0,63})";
    if (id.empty()) return absl::InvalidArgumentError(absl::StrCat(AbslView(field), ": is empty"));
    if (id.size() > kMaxIdLength) {
        return absl::InvalidArgumentError(absl::StrCat(AbslView(field), ": is too long (",
                                                       id.size(), " characters, limit ",
                                                       kMaxIdLength, ")"));
    }
    if (!IsAlnum(id[0])) {
        return absl::InvalidArgumentError(absl::StrCat(
            AbslView(field), ": must start with a letter or digit, not ", Quoted(id[0]), kRule));
    }
    for (std::size_t i = 1; i < id.size(); ++i) {
        if (!IsIdChar(id[i])) {
            return absl::InvalidArgumentError(absl::StrCat(AbslView(field),
                                                           ": has a bad character ", Quoted(id[i]),
                                                           " at position ", i, kRule));
        }
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
