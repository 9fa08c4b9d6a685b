#include "core/io/text_scanner.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <system_error>

#include "core/io/scalar_type.hpp"

namespace soilvol::io::detail {
namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

template <typename T>
std::from_chars_result ParseFloating(std::string_view token, T* value) {
    return std::from_chars(token.data(), token.data() + token.size(), *value,
                           std::chars_format::general);
}

}  // namespace

LineReader::LineReader(std::string_view bytes, std::size_t limit)
    : bytes_(bytes), limit_(std::min(limit, bytes.size())) {}

bool LineReader::Next(std::string_view* line) {
    if (pos_ >= bytes_.size() || hit_limit_) return false;
    const char* begin = bytes_.data() + pos_;
    const auto* newline =
        static_cast<const char*>(std::memchr(begin, '\n', limit_ > pos_ ? limit_ - pos_ : 0));
    std::size_t length = 0;
    if (newline != nullptr) {
        length = static_cast<std::size_t>(newline - begin);
        pos_ += length + 1;
        last_terminated_ = true;
    } else if (limit_ < bytes_.size()) {
        hit_limit_ = true;
        return false;
    } else {
        length = bytes_.size() - pos_;
        pos_ = bytes_.size();
        last_terminated_ = false;
    }
    if (length > 0 && begin[length - 1] == '\r') --length;
    *line = std::string_view(begin, length);
    return true;
}

bool LineReader::NextNonBlank(std::string_view* line) {
    while (Next(line)) {
        if (!IsBlank(*line)) return true;
    }
    return false;
}

bool TokenReader::Next(std::string_view* token) {
    std::size_t start = 0;
    while (start < rest_.size() && IsSpace(rest_[start])) ++start;
    if (start == rest_.size()) {
        rest_ = {};
        return false;
    }
    std::size_t end = start;
    while (end < rest_.size() && !IsSpace(rest_[end])) ++end;
    *token = rest_.substr(start, end - start);
    rest_.remove_prefix(end);
    return true;
}

std::vector<std::string_view> SplitTokens(std::string_view line) {
    std::vector<std::string_view> tokens;
    TokenReader reader(line);
    std::string_view token;
    while (reader.Next(&token)) tokens.push_back(token);
    return tokens;
}

bool IsBlank(std::string_view line) { return std::all_of(line.begin(), line.end(), IsSpace); }

bool ParseUint64(std::string_view token, std::uint64_t* value) {
    if (token.empty()) return false;
    const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
    return error == std::errc() && end == token.data() + token.size();
}

bool ParseFiniteDouble(std::string_view token, double* value) {
    if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') {
        token.remove_prefix(1);
    }
    const auto result = ParseFloating(token, value);
    return result.ec == std::errc() && result.ptr == token.data() + token.size() &&
           std::isfinite(*value);
}

bool ParseCoordinate(std::string_view token, bool as_double, float* value) {
    // from_chars rejects a leading '+', which some writers emit.
    if (token.size() > 1 && token[0] == '+' && token[1] != '-' && token[1] != '+') {
        token.remove_prefix(1);
    }
    if (token.empty()) return false;
    const char* const end = token.data() + token.size();
    if (!as_double) {
        const auto result = ParseFloating(token, value);
        if (result.ec == std::errc() && result.ptr == end) return true;
        if (result.ec != std::errc::result_out_of_range) return false;
    }
    // Doubles, and floats beyond the float range: read as double, then narrow.
    double wide = 0.0;
    const auto result = ParseFloating(token, &wide);
    if (result.ec != std::errc() || result.ptr != end) return false;
    *value = NarrowToFloat(wide);
    return true;
}

std::string Printable(std::string_view text) {
    constexpr std::size_t kMaxChars = 24;
    std::string out;
    for (const char c : text.substr(0, kMaxChars)) {
        out.push_back(c >= 0x20 && c < 0x7f ? c : '?');
    }
    if (text.size() > kMaxChars) out += "...";
    return out;
}

}  // namespace soilvol::io::detail
