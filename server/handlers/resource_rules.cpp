#include "server/handlers/resource_rules.hpp"

#include <algorithm>
#include <cstdint>
#include <random>

#include "absl/strings/escaping.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "server/base/absl_view.hpp"
#include "server/base/status_map.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

constexpr std::string_view kTokenPrefix = "after:";
constexpr std::string_view kRecordTokenPrefix = "before:";
constexpr std::size_t kMaxRequestId = 128;

std::uint64_t Fnv1a(std::string_view bytes) {
    std::uint64_t hash = 1469598103934665603ULL;
    for (const char c : bytes) {
        hash ^= static_cast<unsigned char>(c);
        hash *= 1099511628211ULL;
    }
    return hash;
}

std::uint64_t RandomBits() {
    static thread_local std::mt19937_64 rng(std::random_device{}());
    return rng();
}

}  // namespace

absl::StatusOr<int> PageSizeOf(int page_size) {
    if (page_size < 0) {
        return absl::InvalidArgumentError(
            absl::StrCat("page_size: must not be negative (got ", page_size, ")"));
    }
    return page_size == 0 ? kDefaultPageSize : std::min(page_size, kMaxPageSize);
}

absl::StatusOr<Page> PageOf(const std::vector<std::string>& sorted_ids, int page_size,
                            std::string_view page_token) {
    absl::StatusOr<int> checked = PageSizeOf(page_size);
    if (!checked.ok()) return checked.status();
    const auto size = static_cast<std::size_t>(*checked);
    auto first = sorted_ids.begin();
    if (!page_token.empty()) {
        std::string decoded;
        if (page_token.size() > 256 ||
            !absl::WebSafeBase64Unescape(AbslView(page_token), &decoded) ||
            !absl::StartsWith(decoded, AbslView(kTokenPrefix)) ||
            !ValidateId(decoded.substr(kTokenPrefix.size()), "page_token").ok()) {
            return absl::InvalidArgumentError(
                "page_token: is not a next_page_token of this list; start again without one");
        }
        first = std::upper_bound(sorted_ids.begin(), sorted_ids.end(),
                                 decoded.substr(kTokenPrefix.size()));
    }
    Page page;
    const auto last = first + static_cast<std::ptrdiff_t>(std::min(
                                  size, static_cast<std::size_t>(sorted_ids.end() - first)));
    page.ids.assign(first, last);
    if (last != sorted_ids.end() && !page.ids.empty()) {
        page.next_page_token =
            absl::WebSafeBase64Escape(absl::StrCat(AbslView(kTokenPrefix), page.ids.back()));
    }
    return page;
}

absl::Status ValidateRequestId(std::string_view request_id, std::string_view field) {
    if (request_id.size() > kMaxRequestId) {
        return absl::InvalidArgumentError(
            absl::StrCat(AbslView(field), ": longer than ", kMaxRequestId, " characters"));
    }
    for (const char c : request_id) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '.' || c == '_' || c == ':' || c == '-';
        if (!ok) {
            return absl::InvalidArgumentError(absl::StrCat(
                AbslView(field), ": only letters, digits and . _ : - are allowed (a UUID fits)"));
        }
    }
    return absl::OkStatus();
}

std::string ServerChosenId(std::string_view prefix, std::string_view request_id) {
    const std::uint64_t bits =
        request_id.empty() ? RandomBits()
                           : Fnv1a(absl::StrCat(AbslView(prefix), "/", AbslView(request_id)));
    return absl::StrFormat("%s-%012x", AbslView(prefix), bits & 0xffffffffffffULL);
}

std::string NewEtag() { return absl::StrFormat("%016x", RandomBits()); }

std::string EtagOf(std::string_view payload) { return absl::StrFormat("%016x", Fnv1a(payload)); }

absl::Status CheckEtag(std::string_view expected, std::string_view current, std::string_view what) {
    if (expected.empty() || expected == current) return absl::OkStatus();
    return WithReason(
        absl::AbortedError(absl::StrCat(
            "etag: '", AbslView(expected), "' is not the current etag of ", AbslView(what), " ('",
            AbslView(current), "'): it changed since you read it; read it again")),
        "ETAG_MISMATCH");
}

absl::Status ValidateDisplayName(std::string_view name, std::string_view field) {
    if (name.size() > 200) {
        return absl::InvalidArgumentError(
            absl::StrCat(AbslView(field), ": at most 200 bytes (got ", name.size(), ")"));
    }
    for (const char c : name) {
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) {
            return absl::InvalidArgumentError(
                absl::StrCat(AbslView(field), ": control characters are not allowed"));
        }
    }
    return absl::OkStatus();
}

absl::Status ValidateLabel(std::string_view key, std::string_view value, std::string_view field) {
    const auto allowed = [](char c, bool upper) {
        return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
               c == '-' || (upper && c >= 'A' && c <= 'Z');
    };
    const bool key_ok =
        !key.empty() && key.size() <= 63 && key[0] >= 'a' && key[0] <= 'z' &&
        std::all_of(key.begin(), key.end(), [&](char c) { return allowed(c, false); });
    if (!key_ok) {
        return absl::InvalidArgumentError(
            absl::StrCat(AbslView(field), ": key '", AbslView(key.substr(0, 80)),
                         "' must be 1-63 of [a-z0-9_.-] starting with a letter"));
    }
    if (value.size() > 63 ||
        !std::all_of(value.begin(), value.end(), [&](char c) { return allowed(c, true); })) {
        return absl::InvalidArgumentError(absl::StrCat(AbslView(field), ": the value of '",
                                                       AbslView(key),
                                                       "' must be 0-63 of [A-Za-z0-9_.-]"));
    }
    return absl::OkStatus();
}

std::string RecordPageToken(std::int64_t last_id) {
    return absl::WebSafeBase64Escape(absl::StrCat(AbslView(kRecordTokenPrefix), last_id));
}

absl::StatusOr<std::optional<std::int64_t>> ParseRecordPageToken(std::string_view page_token) {
    if (page_token.empty()) return std::nullopt;
    std::string decoded;
    if (page_token.size() > 64 || !absl::WebSafeBase64Unescape(AbslView(page_token), &decoded) ||
        !absl::StartsWith(decoded, AbslView(kRecordTokenPrefix)) ||
        !ParseRecordId(std::string_view(decoded).substr(kRecordTokenPrefix.size()), "page_token")
             .ok()) {
        return absl::InvalidArgumentError(
            "page_token: is not a next_page_token of this list; start again without one");
    }
    return *ParseRecordId(std::string_view(decoded).substr(kRecordTokenPrefix.size()), "");
}

absl::StatusOr<std::int64_t> ParseRecordId(std::string_view text, std::string_view field) {
    std::int64_t id = 0;
    const bool digits =
        std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; });
    // Canonical decimal only ("02" is not "2"): an id is the text the server printed.
    if (text.empty() || text.size() > 19 || text.front() == '0' || !digits ||
        !absl::SimpleAtoi(AbslView(text), &id) || id <= 0) {
        return absl::InvalidArgumentError(
            absl::StrCat(AbslView(field), ": '", AbslView(text.substr(0, 40)),
                         "' is not an id this server gave (a positive integer)"));
    }
    return id;
}

absl::StatusOr<std::int64_t> ParseResumeId(std::string_view text, std::string_view field) {
    if (text == "0") return 0;
    return ParseRecordId(text, field);
}

}  // namespace soilvol::server
