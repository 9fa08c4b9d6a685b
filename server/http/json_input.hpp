#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "google/protobuf/message.h"

namespace soilvol::server {

/// Protobuf's JSON parser ends its message with a window of the input and a line with a caret
/// under the fault ("reason.\n<input window>\n    ^"), newlines of the input included. A client
/// reads one line: the reason, and where in the body it broke as line, column and byte.
std::string ReadableJsonError(std::string_view json, std::string_view message);

/// Parses proto3 JSON into `message`, ignoring unknown fields (as grpc-gateway: newer clients,
/// older servers); InvalidArgument "<what>: <ReadableJsonError>".
absl::Status ParseJsonInto(std::string_view json, google::protobuf::Message* message,
                           const std::string& what);

}  // namespace soilvol::server
