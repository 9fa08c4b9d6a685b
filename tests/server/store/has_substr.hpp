#pragma once

#include <gtest/gtest.h>

#include "absl/strings/string_view.h"

namespace soilvol::server {

/// Success when `text` contains `part`; the failure quotes both.
inline ::testing::AssertionResult HasSubstr(absl::string_view text, absl::string_view part) {
    if (text.find(part) != absl::string_view::npos) return ::testing::AssertionSuccess();
    return ::testing::AssertionFailure() << "'" << text << "' lacks '" << part << "'";
}

}  // namespace soilvol::server
