#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// One part of a multipart/form-data body (RFC 7578): views into the body.
struct MultipartPart {
    std::string_view name;          ///< Content-Disposition: form-data; name="..."
    std::string_view filename;      ///< filename="..." when a file was attached, else ""
    std::string_view content_type;  ///< the part's Content-Type, "" when absent
    std::string_view data;
};

struct MultipartLimits {
    std::size_t max_parts = 16;
    std::size_t max_header_bytes = 8192;  ///< a part's header block
};

/// The boundary of a `multipart/form-data; boundary=...` Content-Type (quoted or not, 1-70
/// characters of RFC 2046's set). InvalidArgument naming Content-Type otherwise.
absl::StatusOr<std::string> MultipartBoundary(std::string_view content_type);

/// The parts of `body`, in order. InvalidArgument ("multipart body: ...") for a body without the
/// first or the closing delimiter, a part whose header block is malformed, too large or has
/// no form-data name, and more than `limits.max_parts` parts. Linear in the body's size.
absl::StatusOr<std::vector<MultipartPart>> ParseMultipart(std::string_view body,
                                                          std::string_view boundary,
                                                          const MultipartLimits& limits = {});

}  // namespace soilvol::server
