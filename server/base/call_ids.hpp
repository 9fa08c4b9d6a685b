#pragma once

#include <string>
#include <string_view>

namespace soilvol::server {

/// The call's request id: the caller's (REST `X-Request-Id`, gRPC `x-request-id` metadata)
/// when it is 1-128 characters of [A-Za-z0-9._:/+=-], otherwise a new random one (32 hex
/// digits). Logged as `request_id` and echoed in the response's header or initial metadata.
std::string RequestIdOf(std::string_view sent);

/// The trace id of a W3C `traceparent` ("00-<32 hex>-<16 hex>-<2 hex>", not all zero), ""
/// when it is absent or malformed. Logged as `trace_id`.
std::string TraceIdOf(std::string_view traceparent);

}  // namespace soilvol::server
