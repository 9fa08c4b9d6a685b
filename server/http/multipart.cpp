#include "server/http/multipart.hpp"

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr std::string_view kCrlf = "\r\n";
constexpr std::size_t kMaxBoundary = 70;

std::string_view Trim(std::string_view text) {
    while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
    while (!text.empty() && (text.back() == ' ' || text.back() == '\t')) text.remove_suffix(1);
    return text;
}

bool BoundaryCharacter(char c) {
    // RFC 2046 bchars: DIGIT / ALPHA / "'" / "(" / ")" / "+" / "_" / "," / "-" / "." / "/" /
    // ":" / "=" / "?" / " " (not last).
    return absl::ascii_isalnum(static_cast<unsigned char>(c)) ||
           std::string_view("'()+_,-./:=? ").find(c) != std::string_view::npos;
}

absl::Status Malformed(std::size_t part, std::string_view problem) {
    return absl::InvalidArgumentError(
        absl::StrCat("multipart body: part ", part + 1, " ", AbslView(problem)));
}

bool Blank(char c) { return c == ' ' || c == '\t'; }

/// The value of parameter `key` in "form-data; name=\"x\"; filename=y", without its quotes;
/// false when absent. Quoted values may hold ';' and backslash-escaped quotes (kept as sent).
bool Parameter(std::string_view header, std::string_view key, std::string_view* value) {
    const std::size_t size = header.size();
    std::size_t at = header.find(';');
    while (at != std::string_view::npos) {
        ++at;
        while (at < size && Blank(header[at])) ++at;
        const std::size_t equals = header.find('=', at);
        const std::size_t semicolon = header.find(';', at);
        if (equals == std::string_view::npos) return false;
        if (semicolon < equals) {  // a parameter without a value
            at = semicolon;
            continue;
        }
        const std::string_view name = Trim(header.substr(at, equals - at));
        std::size_t pos = equals + 1;
        while (pos < size && Blank(header[pos])) ++pos;
        std::string_view parsed;
        std::size_t after = size;
        if (pos < size && header[pos] == '"') {
            std::size_t end = pos + 1;
            while (end < size && header[end] != '"') end += header[end] == '\\' ? 2 : 1;
            if (end >= size) return false;  // an unterminated quote ends the header
            parsed = header.substr(pos + 1, end - pos - 1);
            after = end + 1;
        } else {
            const std::size_t end = header.find(';', pos);
            parsed =
                Trim(header.substr(pos, end == std::string_view::npos ? size - pos : end - pos));
            after = end == std::string_view::npos ? size : end;
        }
        if (absl::EqualsIgnoreCase(AbslView(name), AbslView(key))) {
            *value = parsed;
            return true;
        }
        at = header.find(';', after);
    }
    return false;
}

/// Fills name, filename and content type from the header block of part `index`.
absl::Status ParseHeaders(std::string_view block, std::size_t index, MultipartPart* part) {
    bool disposition = false;
    while (!block.empty()) {
        const std::size_t end = block.find(kCrlf);
        const std::string_view line = block.substr(0, end);
        block = end == std::string_view::npos ? std::string_view() : block.substr(end + 2);
        const std::size_t colon = line.find(':');
        if (colon == std::string_view::npos || colon == 0) {
            return Malformed(index, "has a header line without a name and ':'");
        }
        const std::string_view name = line.substr(0, colon);
        const std::string_view value = Trim(line.substr(colon + 1));
        if (absl::EqualsIgnoreCase(AbslView(name), "Content-Disposition")) {
            if (disposition) return Malformed(index, "has two Content-Disposition headers");
            disposition = true;
            const std::string_view type = Trim(value.substr(0, value.find(';')));
            if (!absl::EqualsIgnoreCase(AbslView(type), "form-data")) {
                return Malformed(index, "is not form-data");
            }
            if (!Parameter(value, "name", &part->name) || part->name.empty()) {
                return Malformed(index, "has no name");
            }
            Parameter(value, "filename", &part->filename);
        } else if (absl::EqualsIgnoreCase(AbslView(name), "Content-Type")) {
            part->content_type = value;
            if (absl::StartsWithIgnoreCase(AbslView(value), "multipart/")) {
                return Malformed(index, "is itself multipart; send each file as its own part");
            }
        }
    }
    if (!disposition) return Malformed(index, "has no Content-Disposition header");
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::string> MultipartBoundary(std::string_view content_type) {
    const std::string_view type = Trim(content_type.substr(0, content_type.find(';')));
    if (!absl::EqualsIgnoreCase(AbslView(type), "multipart/form-data")) {
        return absl::InvalidArgumentError("Content-Type: is not multipart/form-data");
    }
    std::string_view boundary;
    if (!Parameter(content_type, "boundary", &boundary)) {
        return absl::InvalidArgumentError("Content-Type: multipart/form-data needs a boundary");
    }
    if (boundary.empty() || boundary.size() > kMaxBoundary || boundary.back() == ' ') {
        return absl::InvalidArgumentError(
            "Content-Type: the boundary must be 1-70 characters, not ending in a space");
    }
    for (const char c : boundary) {
        if (!BoundaryCharacter(c)) {
            return absl::InvalidArgumentError(
                "Content-Type: the boundary holds a character RFC 2046 does not allow");
        }
    }
    return std::string(boundary);
}

absl::StatusOr<std::vector<MultipartPart>> ParseMultipart(std::string_view body,
                                                          std::string_view boundary,
                                                          const MultipartLimits& limits) {
    const std::string delimiter = absl::StrCat("--", AbslView(boundary));
    // The first delimiter opens the body or follows the preamble's CRLF.
    std::size_t at = 0;
    if (body.substr(0, delimiter.size()) != delimiter) {
        const std::size_t found = body.find(absl::StrCat("\r\n", delimiter));
        if (found == std::string_view::npos) {
            return absl::InvalidArgumentError("multipart body: no boundary delimiter in the body");
        }
        at = found + 2;
    }
    const std::string next_delimiter = absl::StrCat("\r\n", delimiter);
    std::vector<MultipartPart> parts;
    while (true) {
        at += delimiter.size();
        if (body.substr(at, 2) == "--") return parts;  // the close delimiter
        while (at < body.size() && (body[at] == ' ' || body[at] == '\t')) ++at;  // padding
        if (body.substr(at, 2) != kCrlf) {
            return Malformed(parts.size(), "does not start with CRLF after its delimiter");
        }
        at += 2;
        if (parts.size() == limits.max_parts) {
            return absl::InvalidArgumentError(
                absl::StrCat("multipart body: more than ", limits.max_parts, " parts"));
        }
        MultipartPart part;
        std::size_t headers_end;
        if (body.substr(at, 2) == kCrlf) {
            headers_end = at;  // no header at all
        } else {
            headers_end = body.substr(at, limits.max_header_bytes + 4).find("\r\n\r\n");
            if (headers_end == std::string_view::npos) {
                return Malformed(parts.size(), body.size() - at > limits.max_header_bytes
                                                   ? "has a header block over the limit"
                                                   : "ends inside its header block");
            }
            headers_end += at + 2;
        }
        if (absl::Status headers =
                ParseHeaders(body.substr(at, headers_end - at), parts.size(), &part);
            !headers.ok()) {
            return headers;
        }
        const std::size_t data_start = headers_end + 2;
        const std::size_t data_end = body.find(next_delimiter, data_start);
        if (data_end == std::string_view::npos) {
            return Malformed(parts.size(), "has no closing boundary delimiter after it");
        }
        part.data = body.substr(data_start, data_end - data_start);
        parts.push_back(part);
        at = data_end + 2;
    }
}

}  // namespace soilvol::server
