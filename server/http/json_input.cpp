#include "server/http/json_input.hpp"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "google/protobuf/util/json_util.h"

namespace soilvol::server {

/// Protobuf's JSON parser ends its message with a window of the input and a line with a caret
/// under the fault ("reason.\n<input window>\n    ^"), newlines of the input included. A client
/// reads one line: the reason, and where in the body it broke as line, column and byte.
std::string ReadableJsonError(std::string_view json, std::string_view message) {
    const std::size_t first = message.find('\n');
    const std::size_t last = message.rfind('\n');
    std::string_view reason = message.substr(0, first);
    while (!reason.empty() && (reason.back() == '.' || reason.back() == ' ')) {
        reason.remove_suffix(1);
    }
    if (first == std::string_view::npos || last <= first) return std::string(reason);
    const std::string_view window = message.substr(first + 1, last - first - 1);
    const std::size_t caret = message.find('^', last);
    const std::size_t at = json.find(window);
    if (caret == std::string_view::npos || at == std::string_view::npos) {
        return std::string(reason);
    }
    const std::size_t offset = std::min(json.size(), at + (caret - last - 1));
    const std::string_view before = json.substr(0, offset);
    const std::size_t line_start = before.rfind('\n');
    const std::size_t line =
        1 + static_cast<std::size_t>(std::count(before.begin(), before.end(), '\n'));
    const std::size_t column =
        offset - (line_start == std::string_view::npos ? 0 : line_start + 1) + 1;
    return absl::StrFormat("%s at line %d, column %d (byte %d)", reason, line, column, offset);
}

absl::Status ParseJsonInto(std::string_view json, google::protobuf::Message* message,
                           const std::string& what) {
    google::protobuf::util::JsonParseOptions options;
    options.ignore_unknown_fields = true;  // as grpc-gateway: newer clients, older servers
    const auto parsed = google::protobuf::util::JsonStringToMessage(
        google::protobuf::StringPiece(json.data(), json.size()), message, options);
    if (!parsed.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ": ", ReadableJsonError(json, std::string(parsed.message()))));
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
