#pragma once

// Private to core/io: PCD decoding (see DecodeCloud for the contract).

#include <string_view>

#include "absl/status/statusor.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/pcd_header.hpp"

namespace soilvol::io::detail {

/// Decodes a whole PCD v0.7 file.
absl::StatusOr<DecodedCloud> DecodePcd(std::string_view bytes);

/// Decodes the ascii body that follows `header`.
absl::StatusOr<DecodedCloud> DecodePcdAsciiBody(const PcdHeader& header, std::string_view body);

/// Decodes the binary_compressed body (sizes, then LZF of the field-by-field data).
absl::StatusOr<DecodedCloud> DecodePcdCompressedBody(const PcdHeader& header,
                                                     std::string_view body);

}  // namespace soilvol::io::detail
