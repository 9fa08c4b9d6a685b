#pragma once

#include <cstddef>
#include <string_view>

#include "absl/status/status.h"

namespace soilvol::server {

/// Longest accepted id [characters].
inline constexpr std::size_t kMaxIdLength = 64;

/// Checks that `id` matches [A-Za-z0-9][A-Za-z0-9._-]{0,63}, so it names a file inside the data
/// directory and nothing else ("..", "a/b" and ".hidden" cannot match). InvalidArgument naming
/// `field` and the problem (empty, too long, bad first character, bad character at position N).
absl::Status ValidateId(std::string_view id, std::string_view field);

}  // namespace soilvol::server
