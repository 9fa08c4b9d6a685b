#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// The longest webhook URL accepted [characters].
inline constexpr std::size_t kMaxWebhookUrlLength = 2048;

/// Where a webhook goes: an http or https URL taken apart.
struct WebhookUrl {
    bool tls = false;    ///< https
    std::string host;    ///< lower-case DNS name or IPv4; an IPv6 literal without its brackets
    std::string port;    ///< decimal 1..65535; 80 or 443 when the URL names none
    std::string target;  ///< path and query as given, "/" when the URL has none
    std::string text;    ///< the URL as given
};

/// Takes apart `http://host[:port][/path][?query]` (or https; the scheme in any case), the host a
/// DNS name, a dotted IPv4 address or a bracketed IPv6 literal. InvalidArgument
/// "webhook url: <what is wrong>" for any other scheme, user info, a fragment, spaces, control
/// or non-ASCII characters (percent-encode them), an empty or malformed host, a port outside
/// 1..65535, or more than kMaxWebhookUrlLength characters. The message never repeats the URL.
absl::StatusOr<WebhookUrl> ParseWebhookUrl(std::string_view url);

/// The value of a Host header for `url`: the host (IPv6 in brackets), with ":port" unless the
/// port is the scheme's default.
std::string HostHeaderOf(const WebhookUrl& url);

}  // namespace soilvol::server
