#include "server/webhooks/webhook_url.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cstdint>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr std::size_t kMaxHostLength = 253;  // RFC 1035, without the root's dot
constexpr std::size_t kMaxLabelLength = 63;
constexpr std::size_t kMaxIpv6Length = 45;  // INET6_ADDRSTRLEN - 1

absl::Status UrlError(std::string_view what) {
    return absl::InvalidArgumentError(absl::StrCat("webhook url: ", AbslView(what)));
}

std::vector<std::string_view> SplitDots(std::string_view text) {
    std::vector<std::string_view> parts;
    for (std::size_t start = 0;;) {
        const std::size_t dot = text.find('.', start);
        parts.push_back(text.substr(start, dot - start));
        if (dot == std::string_view::npos) return parts;
        start = dot + 1;
    }
}

std::string Lower(std::string_view text) {
    std::string lower(text);
    for (char& c : lower) c = absl::ascii_tolower(static_cast<unsigned char>(c));
    return lower;
}

// Bytes that may appear nowhere in the URL, named with their offset.
absl::Status CheckBytes(std::string_view url) {
    if (url.size() > kMaxWebhookUrlLength) {
        return UrlError(absl::StrCat("longer than ", kMaxWebhookUrlLength, " characters"));
    }
    for (std::size_t i = 0; i < url.size(); ++i) {
        const auto byte = static_cast<unsigned char>(url[i]);
        if (byte < 0x20 || byte == 0x7f) {
            return UrlError(absl::StrCat("control character at offset ", i));
        }
        if (byte == ' ') return UrlError(absl::StrCat("space at offset ", i));
        if (byte >= 0x80) {
            return UrlError(absl::StrCat("non-ASCII byte at offset ", i, " (percent-encode it)"));
        }
        if (byte == '\\') return UrlError(absl::StrCat("backslash at offset ", i));
        if (byte == '#') return UrlError("a fragment (#) is not allowed");
    }
    return absl::OkStatus();
}

bool IsDigits(std::string_view text) {
    return !text.empty() && text.find_first_not_of("0123456789") == std::string_view::npos;
}

// Four decimal parts of 0..255 without leading zeros (no octal or hexadecimal forms).
bool IsIpv4(std::string_view host) {
    const std::vector<std::string_view> parts = SplitDots(host);
    if (parts.size() != 4) return false;
    for (std::string_view part : parts) {
        if (!IsDigits(part) || part.size() > 3 || (part.size() > 1 && part[0] == '0')) {
            return false;
        }
        int value = 0;
        for (char c : part) value = value * 10 + (c - '0');
        if (value > 255) return false;
    }
    return true;
}

// Letters, digits and inner hyphens, 1..63 a label; a last label of digits only must be IPv4.
absl::Status CheckDnsName(std::string_view host) {
    if (host.size() > kMaxHostLength) {
        return UrlError(absl::StrCat("host longer than ", kMaxHostLength, " characters"));
    }
    const std::vector<std::string_view> labels = SplitDots(host);
    if (IsDigits(labels.back())) {
        return IsIpv4(host) ? absl::OkStatus() : UrlError("malformed IPv4 address");
    }
    for (std::string_view label : labels) {
        if (label.empty() || label.size() > kMaxLabelLength) {
            return UrlError("host has an empty or over-long label");
        }
        for (char c : label) {
            if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '-') {
                return UrlError(absl::StrCat("character '", std::string(1, c), "' in the host"));
            }
        }
        if (label.front() == '-' || label.back() == '-') {
            return UrlError("host label starts or ends with '-'");
        }
    }
    return absl::OkStatus();
}

absl::Status CheckIpv6(std::string_view literal) {
    if (literal.empty() || literal.size() > kMaxIpv6Length ||
        literal.find_first_not_of("0123456789abcdefABCDEF:.") != std::string_view::npos) {
        return UrlError("malformed IPv6 address");
    }
    const std::string text(literal);
    in6_addr address{};
    if (::inet_pton(AF_INET6, text.c_str(), &address) != 1) {
        return UrlError("malformed IPv6 address");
    }
    return absl::OkStatus();
}

// 1..65535 in decimal, as digits only; kept without leading zeros.
absl::StatusOr<std::string> ParsePort(std::string_view text) {
    if (!IsDigits(text)) return UrlError("port must be a decimal number");
    std::uint32_t value = 0;
    for (char c : text) {
        value = value * 10 + static_cast<std::uint32_t>(c - '0');
        if (value > 65535) return UrlError("port out of range 1..65535");
    }
    if (value == 0) return UrlError("port out of range 1..65535");
    return std::to_string(value);
}

// Host and port of the authority (user info already refused).
absl::Status ParseAuthority(std::string_view authority, WebhookUrl& url) {
    std::string_view host = authority;
    std::string_view port;
    bool has_port = false;
    if (!authority.empty() && authority[0] == '[') {
        const std::size_t close = authority.find(']');
        if (close == std::string_view::npos) return UrlError("unclosed '[' in the host");
        host = authority.substr(1, close - 1);
        const std::string_view rest = authority.substr(close + 1);
        if (!rest.empty() && rest[0] != ':') return UrlError("text after the IPv6 address");
        has_port = !rest.empty();
        if (has_port) port = rest.substr(1);
        if (absl::Status status = CheckIpv6(host); !status.ok()) return status;
    } else {
        const std::size_t colon = authority.find(':');
        if (colon != std::string_view::npos) {
            host = authority.substr(0, colon);
            port = authority.substr(colon + 1);
            has_port = true;
        }
        if (host.empty()) return UrlError("empty host");
        if (absl::Status status = CheckDnsName(host); !status.ok()) return status;
    }
    url.host = Lower(host);
    if (!has_port) {
        url.port = url.tls ? "443" : "80";
        return absl::OkStatus();
    }
    absl::StatusOr<std::string> parsed = ParsePort(port);
    if (!parsed.ok()) return parsed.status();
    url.port = *std::move(parsed);
    return absl::OkStatus();
}

bool IsHex(char c) { return absl::ascii_isxdigit(static_cast<unsigned char>(c)); }

// RFC 3986 path and query characters: unreserved, sub-delims, ':', '@', '/', '?' and
// well-formed percent escapes.
absl::Status CheckTarget(std::string_view target) {
    static constexpr std::string_view kAllowed = "-._~!$&'()*+,;=:@/?";
    for (std::size_t i = 0; i < target.size(); ++i) {
        const char c = target[i];
        if (c == '%') {
            if (i + 2 >= target.size() || !IsHex(target[i + 1]) || !IsHex(target[i + 2])) {
                return UrlError("'%' not followed by two hexadecimal digits");
            }
            i += 2;
        } else if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) &&
                   kAllowed.find(c) == std::string_view::npos) {
            return UrlError(absl::StrCat("character '", std::string(1, c),
                                         "' in the path or query (percent-encode it)"));
        }
    }
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<WebhookUrl> ParseWebhookUrl(std::string_view text) {
    if (absl::Status status = CheckBytes(text); !status.ok()) return status;
    // Scheme: http or https, in any case.
    const std::size_t separator = text.find("://");
    if (separator == std::string_view::npos) return UrlError("no scheme (http:// or https://)");
    const std::string scheme = Lower(text.substr(0, separator));
    if (scheme != "http" && scheme != "https") return UrlError("scheme must be http or https");
    WebhookUrl url;
    url.tls = scheme == "https";
    url.text = std::string(text);
    // Authority: up to the path or the query; no user info.
    const std::string_view rest = text.substr(separator + 3);
    const std::size_t end = std::min(rest.find_first_of("/?"), rest.size());
    const std::string_view authority = rest.substr(0, end);
    if (authority.find('@') != std::string_view::npos) {
        return UrlError("user info (user:password@) is not allowed");
    }
    if (absl::Status status = ParseAuthority(authority, url); !status.ok()) return status;
    // Target: path and query, "/" when absent.
    const std::string_view target = rest.substr(end);
    if (absl::Status status = CheckTarget(target); !status.ok()) return status;
    url.target = target.empty() || target[0] == '?' ? absl::StrCat("/", AbslView(target))
                                                    : std::string(target);
    return url;
}

std::string HostHeaderOf(const WebhookUrl& url) {
    const bool ipv6 = url.host.find(':') != std::string::npos;
    std::string header = ipv6 ? absl::StrCat("[", url.host, "]") : url.host;
    if (url.port != (url.tls ? "443" : "80")) absl::StrAppend(&header, ":", url.port);
    return header;
}

}  // namespace soilvol::server
