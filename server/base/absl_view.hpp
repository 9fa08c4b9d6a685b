#pragma once

#include <string_view>

#include "absl/strings/string_view.h"

namespace soilvol::server {

/// `s` as an absl::string_view, for absl::StrCat and friends (this abseil build keeps
/// absl::string_view and std::string_view distinct).
inline absl::string_view AbslView(std::string_view s) { return {s.data(), s.size()}; }

}  // namespace soilvol::server
