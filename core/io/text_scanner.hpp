#pragma once

// Private to core/io: line and token scanning over untrusted text, without iostreams.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace soilvol::io::detail {

/// Longest header accepted [bytes]; a header without its end is rejected after this many.
inline constexpr std::size_t kMaxHeaderBytes = 64 * 1024;
/// Points one cloud may declare (a dense lidar sweep holds a few million); the estimate of the
/// largest stays within the per-request memory budget (server/README.md, Limits).
inline constexpr std::uint64_t kMaxPoints = 5'000'000;
/// Bytes a compressed body may expand to before it is decoded.
inline constexpr std::uint64_t kMaxDecodedBytes = 256ull << 20;

/// Splits bytes into lines ending in '\n' (a '\r' before it is dropped). Lines ending past
/// `limit` bytes are not returned; a last line without '\n' is returned as unterminated.
class LineReader {
  public:
    explicit LineReader(std::string_view bytes, std::size_t limit = std::string_view::npos);

    /// The next line; false at the end of the bytes or when the line crosses the limit.
    bool Next(std::string_view* line);
    /// The next line holding a token, skipping blank lines; false like Next.
    bool NextNonBlank(std::string_view* line);
    /// Offset of the first byte after the last returned line and its newline.
    std::size_t offset() const { return pos_; }
    std::size_t remaining() const { return bytes_.size() - pos_; }
    bool hit_limit() const { return hit_limit_; }
    bool last_line_terminated() const { return last_terminated_; }

  private:
    std::string_view bytes_;
    std::size_t limit_;
    std::size_t pos_ = 0;
    bool hit_limit_ = false;
    bool last_terminated_ = false;
};

/// Whitespace-separated tokens of one line, without allocating.
class TokenReader {
  public:
    explicit TokenReader(std::string_view line) : rest_(line) {}
    /// The next token; false when the line has no more.
    bool Next(std::string_view* token);

  private:
    std::string_view rest_;
};

/// All tokens of a header line.
std::vector<std::string_view> SplitTokens(std::string_view line);

/// True when the line holds only whitespace.
bool IsBlank(std::string_view line);

/// Parses a whole token as a decimal unsigned integer; false on garbage or overflow.
bool ParseUint64(std::string_view token, std::uint64_t* value);

/// Parses a whole token as a decimal number (nan/inf accepted) into float, reading it as a
/// double first when `as_double`; values beyond the float range become +-Inf.
bool ParseCoordinate(std::string_view token, bool as_double, float* value);

/// Parses a whole token as a finite decimal number; false on garbage, NaN, Inf or overflow.
bool ParseFiniteDouble(std::string_view token, double* value);

/// `text` cut to 24 characters with non-printable bytes replaced, for error messages.
std::string Printable(std::string_view text);

}  // namespace soilvol::io::detail
