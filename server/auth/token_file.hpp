#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// What a bearer token may do. `kAdmin` implies the others.
enum class Scope { kRead, kEstimate, kAdmin };

/// "read", "estimate", "admin".
std::string_view ScopeName(Scope scope);

using Sha256 = std::array<std::uint8_t, 32>;

/// One line of a token file: who holds the token, what it may do, and the SHA-256 of the token
/// (the token itself is never stored).
struct TokenEntry {
    std::string name;
    std::vector<Scope> scopes;
    Sha256 sha256{};
    bool Allows(Scope scope) const;
};

/// Limits on a token file: it is read at start and again whenever it changes.
constexpr std::size_t kMaxTokenFileBytes = 1 << 20;
constexpr std::size_t kMaxTokens = 10000;

/// Parses a token file. One token per line, `#` starts a comment:
///
///     <name> <scope>[,<scope>...] sha256:<64 hex digits>
///
/// name: [A-Za-z0-9._@-]{1,64}; scope: read, estimate or admin. InvalidArgument naming the
/// line for anything else, a duplicate name or hash, more than kMaxTokens tokens or more than
/// kMaxTokenFileBytes bytes.
absl::StatusOr<std::vector<TokenEntry>> ParseTokenFile(std::string_view text);

/// SHA-256 of `data` (OpenSSL).
Sha256 Sha256Of(std::string_view data);

}  // namespace soilvol::server
