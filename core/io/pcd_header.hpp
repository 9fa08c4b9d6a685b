#pragma once

// Private to core/io: the PCD v0.7 header and its parser.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

/// One column of FIELDS with its SIZE, TYPE and COUNT.
struct PcdField {
    std::string name;
    std::uint64_t size = 4;  ///< bytes per value: 1, 2, 4 or 8
    char type = 'F';         ///< 'I', 'U' or 'F'
    std::uint64_t count = 1;
};

/// A parsed PCD header with float or double x, y and z fields.
struct PcdHeader {
    std::vector<PcdField> fields;
    std::uint64_t width = 0;
    std::uint64_t height = 0;
    std::uint64_t points = 0;  ///< = width * height, > 0
    PcdData data = PcdData::kAscii;
    std::array<std::size_t, 3> xyz_field{};  ///< indices into `fields`
    std::uint64_t point_size = 0;            ///< sum of size * count [bytes]
    std::size_t body_offset = 0;             ///< first byte after the DATA line
    /// VIEWPOINT: the sensor's pose in the cloud's frame (identity when absent).
    Pose viewpoint = Pose::Identity();
};

/// Storage type of a coordinate field (TYPE F, SIZE 4 or 8).
inline ScalarType CoordinateType(const PcdField& field) {
    return field.size == 8 ? ScalarType::kFloat64 : ScalarType::kFloat32;
}

/// Parses the header at the start of `bytes`. A header that is malformed, longer than
/// kMaxHeaderBytes, without DATA, without x/y/z of TYPE F and SIZE 4 or 8, with
/// POINTS != WIDTH * HEIGHT, or with zero points gets InvalidArgument.
absl::StatusOr<PcdHeader> ParsePcdHeader(std::string_view bytes);

}  // namespace soilvol::io::detail
