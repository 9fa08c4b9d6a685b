#pragma once

// Private to core/io: PLY decoding (see DecodeCloud for the contract).

#include <string_view>

#include "absl/status/statusor.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/ply_header.hpp"

namespace soilvol::io::detail {

/// Decodes a whole PLY file; `bytes` start with the "ply" line.
absl::StatusOr<DecodedCloud> DecodePly(std::string_view bytes);

/// Decodes the ascii body that follows `header`.
absl::StatusOr<DecodedCloud> DecodePlyAsciiBody(const PlyHeader& header, std::string_view body);

/// Decodes the binary (either byte order) body that follows `header`.
absl::StatusOr<DecodedCloud> DecodePlyBinaryBody(const PlyHeader& header, std::string_view body);

}  // namespace soilvol::io::detail
