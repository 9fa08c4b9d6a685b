#pragma once

// Shared helpers for the core/io tests: seeded clouds, byte builders, status matchers.

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <random>
#include <string>
#include <string_view>

#include "core/io/cloud_codec.hpp"

namespace soilvol::io::test {

/// `count` points uniform in [-50, 50) m, reproducible from `seed`.
inline Cloud RandomCloud(std::size_t count, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-50.0f, 50.0f);
    Cloud cloud(count);
    for (Eigen::Vector3f& point : cloud) {
        point = {coordinate(rng), coordinate(rng), coordinate(rng)};
    }
    return cloud;
}

/// Appends the bytes of `value` in little-endian (or big-endian) order.
template <typename T>
void Append(T value, std::string* out, bool big_endian = false) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    if (big_endian) {
        for (std::size_t i = sizeof(T); i > 0; --i) out->push_back(bytes[i - 1]);
    } else {
        out->append(bytes, sizeof(T));
    }
}

/// True when both clouds hold bit-identical points in the same order.
inline ::testing::AssertionResult SameBits(const Cloud& actual, const Cloud& expected) {
    if (actual.size() != expected.size()) {
        return ::testing::AssertionFailure()
               << "size " << actual.size() << " != " << expected.size();
    }
    for (std::size_t i = 0; i < actual.size(); ++i) {
        if (std::memcmp(actual[i].data(), expected[i].data(), 3 * sizeof(float)) != 0) {
            return ::testing::AssertionFailure() << "point " << i << ": " << actual[i].transpose()
                                                 << " != " << expected[i].transpose();
        }
    }
    return ::testing::AssertionSuccess();
}

/// True when `result` is InvalidArgument with a message containing `needle`.
inline ::testing::AssertionResult IsInvalidWith(const absl::StatusOr<DecodedCloud>& result,
                                                std::string_view needle) {
    if (result.ok()) return ::testing::AssertionFailure() << "decoded OK, expected an error";
    const absl::Status& status = result.status();
    if (status.code() != absl::StatusCode::kInvalidArgument) {
        return ::testing::AssertionFailure() << "wrong code: " << status;
    }
    if (std::string(status.message()).find(needle) == std::string::npos) {
        return ::testing::AssertionFailure()
               << "message \"" << status.message() << "\" lacks \"" << needle << "\"";
    }
    return ::testing::AssertionSuccess();
}

}  // namespace soilvol::io::test
