#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace soilvol::server {

/// The one place where core statuses meet the transports. absl and gRPC share code numbers;
/// HTTP follows the standard gRPC mapping (google/rpc/code.proto, as grpc-gateway does).
int HttpStatusFor(absl::StatusCode code);

/// Canonical name of a code: "INVALID_ARGUMENT", "NOT_FOUND", ...
std::string_view CodeName(absl::StatusCode code);

/// `status` with `context` prepended to its message ("scan.cloud.data: ..."); OK stays OK.
absl::Status Annotate(const absl::Status& status, absl::string_view context);

/// {"code": <grpc code>, "message": "...", "details": []}
std::string ErrorJson(const absl::Status& status);

/// `text` as a JSON string literal, quotes included.
std::string JsonQuote(std::string_view text);

}  // namespace soilvol::server
