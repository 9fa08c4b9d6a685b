#include "server/http/query_string.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

int HexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

}  // namespace

absl::StatusOr<std::string> PercentDecode(std::string_view text, bool plus_is_space) {
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        if (text[i] != '%') {
            out += plus_is_space && text[i] == '+' ? ' ' : text[i];
            continue;
        }
        const int hi = i + 2 < text.size() ? HexValue(text[i + 1]) : -1;
        const int lo = i + 2 < text.size() ? HexValue(text[i + 2]) : -1;
        if (hi < 0 || lo < 0) {
            return absl::InvalidArgumentError(
                absl::StrCat("bad percent-encoding in '", AbslView(text.substr(0, 200)), "'"));
        }
        out += static_cast<char>(hi * 16 + lo);
        i += 2;
    }
    return out;
}

absl::StatusOr<std::vector<std::pair<std::string, std::string>>> ParseQuery(
    std::string_view query) {
    std::vector<std::pair<std::string, std::string>> pairs;
    for (absl::string_view absl_part : absl::StrSplit(AbslView(query), '&', absl::SkipEmpty())) {
        const std::string_view part(absl_part.data(), absl_part.size());
        const std::size_t equals = part.find('=');
        absl::StatusOr<std::string> name = PercentDecode(part.substr(0, equals), true);
        if (!name.ok()) return name.status();
        absl::StatusOr<std::string> value =
            PercentDecode(equals == std::string_view::npos ? "" : part.substr(equals + 1), true);
        if (!value.ok()) return value.status();
        pairs.emplace_back(*std::move(name), *std::move(value));
    }
    return pairs;
}

}  // namespace soilvol::server
