#include "server/base/logging.hpp"

#include <cmath>
#include <memory>

#include "absl/strings/str_cat.h"
#include "server/base/status_map.hpp"
#include "spdlog/sinks/stdout_sinks.h"
#include "spdlog/spdlog.h"

namespace soilvol::server {
namespace {

bool g_json = false;

bool IsBare(std::string_view value) {
    return !value.empty() && value.find_first_of(" \"=\t\n\r") == std::string_view::npos;
}

// Empty text and non-finite numbers carry nothing: their fields are left out.
bool Skipped(const LogField& field) {
    return field.quoted ? field.value.empty() : field.value == "null";
}

std::string Format(std::string_view message, std::initializer_list<LogField> fields) {
    std::string line;
    if (g_json) {
        line = absl::StrCat("\"msg\":", JsonQuote(message));
        for (const LogField& f : fields) {
            if (Skipped(f)) continue;
            absl::StrAppend(&line, ",", JsonQuote(f.key), ":",
                            f.quoted ? JsonQuote(f.value) : f.value);
        }
        return line;
    }
    line = std::string(message);
    for (const LogField& f : fields) {
        if (Skipped(f)) continue;
        absl::StrAppend(&line, " ", f.key, "=",
                        f.quoted && !IsBare(f.value) ? JsonQuote(f.value) : f.value);
    }
    return line;
}

}  // namespace

LogField::LogField(std::string_view k, double v)
    : key(k), value(std::isfinite(v) ? absl::StrCat(v) : "null"), quoted(false) {}

LogField::LogField(std::string_view k, long long v)
    : key(k), value(absl::StrCat(v)), quoted(false) {}

absl::Status ConfigureLogging(const std::string& level, const std::string& format) {
    g_json = format == "json";
    auto logger = std::make_shared<spdlog::logger>(
        "soilvol", std::make_shared<spdlog::sinks::stderr_sink_mt>());
    logger->set_pattern(g_json ? R"({"ts":"%Y-%m-%dT%H:%M:%S.%eZ","level":"%l",%v})"
                               : "%Y-%m-%dT%H:%M:%S.%eZ %l %v",
                        spdlog::pattern_time_type::utc);
    const spdlog::level::level_enum parsed = spdlog::level::from_str(level);
    if (parsed == spdlog::level::off && level != "off") {
        return absl::InvalidArgumentError(absl::StrCat("--log-level: unknown level '", level, "'"));
    }
    logger->set_level(parsed);
    logger->flush_on(spdlog::level::info);
    spdlog::set_default_logger(logger);
    return absl::OkStatus();
}

void LogEvent(LogLevel level, std::string_view message, std::initializer_list<LogField> fields) {
    const std::string line = Format(message, fields);
    switch (level) {
        case LogLevel::kDebug:
            spdlog::debug("{}", line);
            break;
        case LogLevel::kInfo:
            spdlog::info("{}", line);
            break;
        case LogLevel::kWarn:
            spdlog::warn("{}", line);
            break;
        case LogLevel::kError:
            spdlog::error("{}", line);
            break;
    }
}

}  // namespace soilvol::server
