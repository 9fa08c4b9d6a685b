#pragma once

#include <initializer_list>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"

namespace soilvol::server {

enum class LogLevel { kDebug, kInfo, kWarn, kError };

/// One key=value of a log line. Numbers are written bare in JSON, text is quoted.
struct LogField {
    LogField(std::string_view k, std::string_view v) : key(k), value(v), quoted(true) {}
    LogField(std::string_view k, const char* v) : key(k), value(v), quoted(true) {}
    LogField(std::string_view k, const std::string& v) : key(k), value(v), quoted(true) {}
    LogField(std::string_view k, absl::string_view v)
        : key(k), value(v.data(), v.size()), quoted(true) {}
    LogField(std::string_view k, double v);
    LogField(std::string_view k, long long v);
    LogField(std::string_view k, int v) : LogField(k, static_cast<long long>(v)) {}
    LogField(std::string_view k, std::size_t v) : LogField(k, static_cast<long long>(v)) {}

    std::string key;
    std::string value;
    bool quoted;
};

/// Sets up spdlog's default logger on stderr: `level` as in ServerOptions, `format` "text"
/// (`2026-11-22T10:00:00.123Z info msg key=value ...`) or "json" (one object per line).
absl::Status ConfigureLogging(const std::string& level, const std::string& format);

/// One event: a short message and its fields.
void LogEvent(LogLevel level, std::string_view message, std::initializer_list<LogField> fields);

}  // namespace soilvol::server
