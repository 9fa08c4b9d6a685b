#pragma once

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// `text` with its %XX escapes decoded ('+' as a space when `plus_is_space`, as in a query);
/// InvalidArgument for a '%' not followed by two hex digits.
absl::StatusOr<std::string> PercentDecode(std::string_view text, bool plus_is_space = false);

/// The name=value pairs of a query string (after '?'), percent-decoded, '+' read as a space;
/// a name without '=' has the value "". InvalidArgument for bad percent-encoding.
absl::StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(std::string_view query);

}  // namespace soilvol::server
