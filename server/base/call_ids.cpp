#include "server/base/call_ids.hpp"

#include <cstdint>
#include <random>

#include "absl/strings/str_format.h"

namespace soilvol::server {
namespace {

constexpr std::size_t kMaxRequestId = 128;

bool IdCharacter(char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == ':' || c == '/' || c == '+' || c == '=' || c == '-';
}

bool LowerHex(std::string_view text) {
    for (const char c : text) {
        if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
    }
    return true;
}

bool AllZero(std::string_view text) {
    return text.find_first_not_of('0') == std::string_view::npos;
}

}  // namespace

std::string RequestIdOf(std::string_view sent) {
    bool valid = !sent.empty() && sent.size() <= kMaxRequestId;
    for (const char c : sent) valid = valid && IdCharacter(c);
    if (valid) return std::string(sent);
    static thread_local std::mt19937_64 rng(std::random_device{}());
    return absl::StrFormat("%016x%016x", rng(), rng());
}

std::string TraceIdOf(std::string_view traceparent) {
    // version "-" trace-id "-" parent-id "-" flags; a later version may append fields.
    if (traceparent.size() < 55 || traceparent[2] != '-' || traceparent[35] != '-' ||
        traceparent[52] != '-' || (traceparent.size() > 55 && traceparent[55] != '-')) {
        return "";
    }
    const std::string_view version = traceparent.substr(0, 2);
    const std::string_view trace = traceparent.substr(3, 32);
    const std::string_view parent = traceparent.substr(36, 16);
    const std::string_view flags = traceparent.substr(53, 2);
    if (!LowerHex(version) || version == "ff" || (version == "00" && traceparent.size() != 55) ||
        !LowerHex(trace) || !LowerHex(parent) || !LowerHex(flags) || AllZero(trace) ||
        AllZero(parent)) {
        return "";
    }
    return std::string(trace);
}

}  // namespace soilvol::server
