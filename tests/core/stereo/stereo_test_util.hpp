#pragma once

// Shared helpers for the core/stereo tests: OpenCV's sample pairs, files, status matchers.

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/stereo/calibration.hpp"

namespace soilvol::stereo::test {

/// Debian's opencv-doc sample data (plain .jpg files; pair 10 is missing upstream).
inline const std::string kSampleDir = "/usr/share/doc/opencv-doc/examples/data/";

/// The bytes of a file; empty when it cannot be read.
inline std::string ReadFile(const std::string& path) {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return {};
    std::string bytes(static_cast<std::size_t>(in.tellg()), '\0');
    in.seekg(0);
    in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return in ? bytes : std::string();
}

/// The 13 left/right chessboard pairs of OpenCV's stereo_calib sample (9x6 inner corners), in
/// its order; empty when opencv-doc is not installed.
inline std::vector<ImagePair> SamplePairs() {
    std::vector<ImagePair> pairs;
    for (int i = 1; i <= 14; ++i) {
        if (i == 10) continue;
        char left[16];
        char right[16];
        std::snprintf(left, sizeof(left), "left%02d.jpg", i);
        std::snprintf(right, sizeof(right), "right%02d.jpg", i);
        ImagePair pair{ReadFile(kSampleDir + left), ReadFile(kSampleDir + right)};
        if (pair.left.empty() || pair.right.empty()) return {};
        pairs.push_back(std::move(pair));
    }
    return pairs;
}

/// True under CI (CI=true), where scripts/install-deps.sh installs opencv-doc.
inline bool UnderCi() {
    const char* ci = std::getenv("CI");
    return ci != nullptr && std::string_view(ci) == "true";
}

/// The start of a test that needs opencv-doc's files: skipped where they are not installed,
/// failed under CI, where a skip would hide a test that no longer runs.
#define SOILVOL_NEED_SAMPLES(missing, what)                                           \
    if (missing) {                                                                    \
        if (::soilvol::stereo::test::UnderCi()) {                                     \
            FAIL() << what                                                            \
                   << " not installed, under CI=true (install-deps.sh test installs " \
                      "opencv-doc)";                                                  \
        } else {                                                                      \
            GTEST_SKIP() << what << " not installed";                                 \
        }                                                                             \
    }

/// True when `status` has `code` and a message containing `needle`.
inline ::testing::AssertionResult HasError(const absl::Status& status, absl::StatusCode code,
                                           std::string_view needle) {
    if (status.code() != code) {
        return ::testing::AssertionFailure()
               << "got " << status << ", expected code " << absl::StatusCodeToString(code);
    }
    if (status.message().find(absl::string_view(needle.data(), needle.size())) ==
        absl::string_view::npos) {
        return ::testing::AssertionFailure()
               << "message '" << status.message() << "' lacks '" << needle << "'";
    }
    return ::testing::AssertionSuccess();
}

template <typename T>
::testing::AssertionResult IsInvalidWith(const absl::StatusOr<T>& result, std::string_view needle) {
    if (result.ok()) return ::testing::AssertionFailure() << "OK, expected InvalidArgument";
    return HasError(result.status(), absl::StatusCode::kInvalidArgument, needle);
}

}  // namespace soilvol::stereo::test
