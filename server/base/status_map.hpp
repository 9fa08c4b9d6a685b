#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "google/rpc/status.pb.h"

namespace soilvol::server {

/// The one place where core statuses meet the transports. absl and gRPC share code numbers;
/// HTTP follows the standard gRPC mapping (google/rpc/code.proto, as grpc-gateway does).
int HttpStatusFor(absl::StatusCode code);

/// Canonical name of a code: "INVALID_ARGUMENT", "NOT_FOUND", ...
std::string_view CodeName(absl::StatusCode code);

/// `status` with `context` prepended to its message ("scan.cloud.data: ..."); OK stays OK.
absl::Status Annotate(const absl::Status& status, absl::string_view context);

/// `status` carrying an ErrorInfo reason more precise than its code's name ("ETAG_MISMATCH").
absl::Status WithReason(absl::Status status, std::string_view reason);

/// The request field a message names: the dotted snake_case path before its first ": "
/// ("scan.cloud.data", "additional_scans[1].opening"), "" when it names none.
std::string FieldOf(absl::string_view message);

/// The reason of a request past a size limit: RESOURCE_EXHAUSTED that a retry does not cure.
inline constexpr std::string_view kReasonTooLarge = "REQUEST_TOO_LARGE";

/// Seconds a caller should wait before retrying (RESOURCE_EXHAUSTED and UNAVAILABLE but too
/// large), 0 for errors a retry does not cure.
int RetryAfterSeconds(const absl::Status& status);

/// `status` as a google.rpc.Status: the message as printable ASCII (other bytes as
/// \xNN) and the details ErrorInfo{reason, domain "soilvol", metadata.field}, BadRequest (for
/// INVALID_ARGUMENT and OUT_OF_RANGE naming a field) and RetryInfo (RESOURCE_EXHAUSTED,
/// UNAVAILABLE).
google::rpc::Status RpcStatusOf(const absl::Status& status);
/// RpcStatusOf serialized; "" for OK.
std::string RpcStatusBytes(const absl::Status& status);

/// The printable-ASCII message RpcStatusBytes carries.
std::string SafeMessage(absl::string_view message);

/// The same google.rpc.Status in proto3 JSON: {"code":3,"message":"...","details":[{"@type":..}]}
std::string ErrorJson(const absl::Status& status);

/// `text` as a JSON string literal, quotes included.
std::string JsonQuote(std::string_view text);

}  // namespace soilvol::server
