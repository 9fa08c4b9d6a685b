#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace soilvol::server {

/// The signature header of a webhook (Stripe's scheme): `t=<unix_seconds>,v1=<hex>`, the hex
/// being the lower-case HMAC-SHA256 of `<unix_seconds>.<body>` under `secret`. Empty only when
/// OpenSSL fails.
std::string SignatureHeader(std::string_view secret, std::int64_t unix_seconds,
                            std::string_view body);

/// True when `header` has one `t=` field within `tolerance_seconds` of `now_seconds` [s] and a
/// `v1=` field (of possibly several) that is the signature of `body` under `secret`, compared
/// in constant time. Fields in any order, unknown ones ignored; false for a malformed header.
bool VerifySignature(std::string_view header, std::string_view secret, std::string_view body,
                     std::int64_t now_seconds, std::int64_t tolerance_seconds);

}  // namespace soilvol::server
