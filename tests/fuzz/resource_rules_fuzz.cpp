// libFuzzer: the parsers of client-chosen resource strings (server/resource_rules) on any bytes:
// estimate ids, record page tokens, request ids, display names and labels. What they accept
// must be what they promise: a positive id that prints back to the same text, a token that
// names an id the server could have made, and refusals that name their field.
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "absl/strings/str_cat.h"
#include "server/base/status_map.hpp"
#include "server/handlers/resource_rules.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    namespace s = soilvol::server;
    const std::string_view text(reinterpret_cast<const char*>(data), size);
    if (const auto id = s::ParseRecordId(text, "estimate_id"); id.ok()) {
        if (*id <= 0 || absl::StrCat(*id) != text) std::abort();
    } else if (s::FieldOf(id.status().message()) != "estimate_id") {
        std::abort();
    }
    if (const auto token = s::ParseRecordPageToken(text); token.ok()) {
        if (token->has_value() &&
            (**token <= 0 || *s::ParseRecordPageToken(s::RecordPageToken(**token)) != *token)) {
            std::abort();
        }
    } else if (s::FieldOf(token.status().message()) != "page_token") {
        std::abort();
    }
    if (const auto page = s::PageOf({"a", "b", "c"}, 2, text); page.ok() && page->ids.size() > 2) {
        std::abort();
    }
    s::ValidateRequestId(text, "request_id").IgnoreError();
    s::ValidateDisplayName(text, "display_name").IgnoreError();
    const std::size_t half = size / 2;
    s::ValidateLabel(text.substr(0, half), text.substr(half), "labels").IgnoreError();
    return 0;
}
