#include "server/options.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "server/cpu_budget.hpp"

namespace soilvol::server {
namespace {

constexpr std::array<const char*, 7> kLogLevels = {"trace", "debug",    "info", "warn",
                                                   "error", "critical", "off"};

absl::Status Invalid(const std::string& flag, const std::string& problem) {
    return absl::InvalidArgumentError(absl::StrCat("--", flag, ": ", problem));
}

}  // namespace

absl::Status ValidateAddress(const std::string& address, const std::string& flag) {
    const std::size_t colon = address.rfind(':');
    if (colon == std::string::npos || colon == 0) {
        return Invalid(flag, absl::StrCat("'", address, "' is not host:port"));
    }
    const std::string host = address.substr(0, colon);
    const std::string port = address.substr(colon + 1);
    int value = -1;
    if (port.empty() || !std::all_of(port.begin(), port.end(), ::isdigit) ||
        !absl::SimpleAtoi(port, &value) || value > 65535) {
        return Invalid(flag, absl::StrCat("port '", port, "' is not a number in [0, 65535]"));
    }
    const bool bracketed = host.front() == '[' && host.back() == ']';
    if (!bracketed && host.find_first_of("[]/ ") != std::string::npos) {
        return Invalid(flag, absl::StrCat("host '", host, "' is not a host name or address"));
    }
    return absl::OkStatus();
}

absl::Status ValidateOptions(const ServerOptions& o) {
    if (absl::Status s = ValidateAddress(o.grpc_address, "grpc-address"); !s.ok()) return s;
    if (absl::Status s = ValidateAddress(o.http_address, "http-address"); !s.ok()) return s;
    if (o.data_dir.empty()) return Invalid("data-dir", "must not be empty");
    if (o.workers < 0 || o.workers > 256) return Invalid("workers", "must be in [0, 256]");
    if (o.max_queue < 0 || o.max_queue > 100000) {
        return Invalid("max-queue", "must be in [0, 100000]");
    }
    if (o.max_message_mb < 1 || o.max_message_mb > 1024) {
        return Invalid("max-message-mb", "must be in [1, 1024]");
    }
    if (std::find(kLogLevels.begin(), kLogLevels.end(), o.log_level) == kLogLevels.end()) {
        return Invalid("log-level", absl::StrCat("'", o.log_level,
                                                 "' is not one of trace, debug, info, warn, "
                                                 "error, critical, off"));
    }
    if (o.log_format != "text" && o.log_format != "json") {
        return Invalid("log-format", absl::StrCat("'", o.log_format, "' is not text or json"));
    }
    for (const std::string& origin : o.cors_origins) {
        if (origin != "*" && origin.rfind("http://", 0) != 0 && origin.rfind("https://", 0) != 0) {
            return Invalid("cors-origin",
                           absl::StrCat("'", origin, "' is not * or an http(s):// origin"));
        }
    }
    if (!std::isfinite(o.shutdown_grace_s) || o.shutdown_grace_s < 0.0 ||
        o.shutdown_grace_s > 3600.0) {
        return Invalid("shutdown-grace-s", "must be in [0, 3600]");
    }
    if (o.http_threads < 0 || o.http_threads > 1024) {
        return Invalid("http-threads", "must be in [0, 1024]");
    }
    return absl::OkStatus();
}

ServerOptions ResolveOptions(ServerOptions options) {
    if (options.cpus == 0) options.cpus = AvailableCpus();
    if (options.workers == 0) options.workers = options.cpus;
    if (options.max_queue == 0) options.max_queue = 4 * options.workers;
    if (options.http_threads == 0) {
        options.http_threads = std::min(1024, 2 * (options.workers + options.max_queue) + 4);
    }
    return options;
}

}  // namespace soilvol::server
