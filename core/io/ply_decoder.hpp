#pragma once

// Private to core/io: PLY decoding (see DecodeCloud and DecodeMesh for the contracts).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "core/io/cloud_codec.hpp"
#include "core/io/ply_header.hpp"
#include "core/io/text_scanner.hpp"

namespace soilvol::io::detail {

/// Decodes a whole PLY file; `bytes` start with the "ply" line.
absl::StatusOr<DecodedCloud> DecodePly(std::string_view bytes);

/// Decodes the ascii body that follows `header`.
absl::StatusOr<DecodedCloud> DecodePlyAsciiBody(const PlyHeader& header, std::string_view body);

/// Decodes the binary (either byte order) body that follows `header`.
absl::StatusOr<DecodedCloud> DecodePlyBinaryBody(const PlyHeader& header, std::string_view body);

// Helpers shared with the mesh decoder (ply_mesh_decoder.cpp).

/// Smallest size of one binary entry [bytes] (lists counted as empty); `fixed` without lists.
struct PlyEntryLayout {
    std::uint64_t min_stride = 0;
    bool fixed = true;
};

PlyEntryLayout LayoutOf(const PlyElement& element);

/// InvalidArgument unless `element.count` entries of `layout.min_stride` bytes fit in
/// `available` bytes (checked before anything is allocated or walked).
absl::Status CheckBinaryFits(const PlyElement& element, const PlyEntryLayout& layout,
                             std::size_t available);

/// Size of the binary entry at the front of `data`, walking list counts; stores each
/// property's offset in `offsets` when given. A truncated entry or a negative list count gets
/// InvalidArgument.
absl::StatusOr<std::size_t> BinaryEntrySize(const PlyElement& element, std::string_view data,
                                            bool swap, std::vector<std::size_t>* offsets);

/// Size of the whole binary element at the front of `data`; InvalidArgument as above.
absl::StatusOr<std::size_t> SkipBinaryElement(const PlyElement& element, std::string_view data,
                                              bool swap);

/// InvalidArgument unless `element.count` ascii lines can fit in `available` bytes.
absl::Status CheckAsciiFits(const PlyElement& element, std::size_t available);

/// The error for an ascii element whose lines end after `read` of them.
absl::Status AsciiEndsEarly(const PlyElement& element, std::uint64_t read);

/// Skips the ascii lines of `element`; InvalidArgument when they cannot fit or end early.
absl::Status SkipAsciiElement(const PlyElement& element, LineReader* lines);

/// Reads x/y/z (slots given by `axis_of`, -1 for other properties) from the ascii line of
/// vertex `index`; too few values or a coordinate that is not a number get InvalidArgument.
absl::Status ParseAsciiVertexLine(const PlyElement& vertex, const std::vector<int>& axis_of,
                                  std::string_view line, std::uint64_t index,
                                  std::array<float, 3>* xyz);

}  // namespace soilvol::io::detail
