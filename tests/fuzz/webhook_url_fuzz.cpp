// libFuzzer: the webhook URL parser on any bytes. An accepted URL has a non-empty host of safe
// characters, a port of 1..65535 without leading zeros, a target that starts with '/' and holds
// no space, control character or '#', and parses again to the same parts.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "server/webhooks/webhook_url.hpp"

namespace {

bool SafeHost(const std::string& host) {
    if (host.empty() || host.size() > 253) return false;
    for (char c : host) {
        const bool ok =
            (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '-' || c == '.' || c == ':';
        if (!ok) return false;
    }
    return true;
}

bool ValidPort(const std::string& port) {
    if (port.empty() || port.size() > 5 || port[0] == '0') return false;
    if (port.find_first_not_of("0123456789") != std::string::npos) return false;
    const long value = std::strtol(port.c_str(), nullptr, 10);
    return value >= 1 && value <= 65535;
}

bool SafeTarget(const std::string& target) {
    if (target.empty() || target[0] != '/') return false;
    for (char c : target) {
        const auto byte = static_cast<unsigned char>(c);
        if (byte <= 0x20 || byte >= 0x7f || c == '#' || c == '\\') return false;
    }
    return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    const auto url = soilvol::server::ParseWebhookUrl(text);
    if (!url.ok()) {
        if (url.status().message().substr(0, 13) != "webhook url: ") std::abort();
        return 0;
    }
    if (size > soilvol::server::kMaxWebhookUrlLength || url->text != text) std::abort();
    if (!SafeHost(url->host) || !ValidPort(url->port) || !SafeTarget(url->target)) std::abort();
    // The parts put together again read the same.
    const std::string host =
        url->host.find(':') != std::string::npos ? "[" + url->host + "]" : url->host;
    const std::string again =
        (url->tls ? "https://" : "http://") + host + ":" + url->port + url->target;
    const auto reparsed = soilvol::server::ParseWebhookUrl(again);
    if (!reparsed.ok() || reparsed->tls != url->tls || reparsed->host != url->host ||
        reparsed->port != url->port || reparsed->target != url->target) {
        std::abort();
    }
    return 0;
}
