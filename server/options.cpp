#include "server/options.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/time/time.h"
#include "server/dispatch/cpu_budget.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/records/production.hpp"

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

namespace {

/// Addresses, the data directory, records, the worker pool and request sizes.
absl::Status ValidateServiceOptions(const ServerOptions& o) {
    if (absl::Status s = ValidateAddress(o.grpc_address, "grpc-address"); !s.ok()) return s;
    if (absl::Status s = ValidateAddress(o.http_address, "http-address"); !s.ok()) return s;
    if (o.data_dir.empty()) return Invalid("data-dir", "must not be empty");
    if (o.records_max_per_container < 1) {
        return Invalid("records-max-per-container", "must be at least 1");
    }
    if (!(o.records_max_age_days > 0.0 && o.records_max_age_days <= 36500.0)) {
        return Invalid("records-max-age-days", "must be in (0, 36500]");
    }
    if (o.max_watches < 1 || o.max_watches > 100000) {
        return Invalid("max-watches", "must be in [1, 100000]");
    }
    if (!(o.watch_heartbeat_s >= 0.1 && o.watch_heartbeat_s <= 60.0)) {
        return Invalid("watch-heartbeat-seconds", "must be in [0.1, 60]");
    }
    if (!(o.watch_coalesce_s >= 0.0 && o.watch_coalesce_s <= 1.0)) {
        return Invalid("watch-coalesce-seconds", "must be in [0, 1]");
    }
    if (o.metrics_max_containers < 1 || o.metrics_max_containers > 10000) {
        return Invalid("metrics-max-containers", "must be in [1, 10000]");
    }
    if (o.workers < 0 || o.workers > 256) return Invalid("workers", "must be in [0, 256]");
    if (o.max_queue < 0 || o.max_queue > 100000) {
        return Invalid("max-queue", "must be in [0, 100000]");
    }
    if (o.max_message_mb < 1 || o.max_message_mb > 1024) {
        return Invalid("max-message-mb", "must be in [1, 1024]");
    }
    if (!(o.capacity_warning_share > 0.0 && o.capacity_warning_share <= 1.0)) {
        return Invalid("capacity-warning-share", "must be in (0, 1]");
    }
    if (!(o.load_idle_s >= 0.0 && o.load_idle_s <= 7 * 86400.0)) {
        return Invalid("load-idle-seconds", "must be in [0, 604800] (0: never)");
    }
    if (absl::Status zone = LoadSiteZone(o.site_time_zone, "site-time-zone").status(); !zone.ok()) {
        return Invalid("site-time-zone", std::string(zone.message().substr(16)));
    }
    if (absl::Status starts = ParseShiftStarts(o.shift_starts, "shift-starts").status();
        !starts.ok()) {
        return Invalid("shift-starts", std::string(starts.message().substr(14)));
    }
    if (absl::Status rules = ParseAlertRules(o.alert_rules).status(); !rules.ok()) {
        return absl::InvalidArgumentError(rules.message());
    }
    if (!(o.webhook_max_age_hours > 0.0 && o.webhook_max_age_hours <= 720.0)) {
        return Invalid("webhook-max-age-hours", "must be in (0, 720]");
    }
    if (o.webhook_lease_s < 10 || o.webhook_lease_s > 600) {
        return Invalid("webhook-lease-seconds", "must be in [10, 600]");
    }
    return absl::OkStatus();
}

/// Logging, browsers, shutdown and the REST and gRPC connection limits.
absl::Status ValidateConnectionOptions(const ServerOptions& o) {
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
    if (o.http_threads < 0 || o.http_threads > 64) {
        return Invalid("http-threads", "must be in [0, 64]");
    }
    if (o.http_max_connections < 1 || o.http_max_connections > 100000) {
        return Invalid("http-max-connections", "must be in [1, 100000]");
    }
    for (const auto& [flag, seconds] :
         {std::pair<const char*, double>{"http-header-timeout-s", o.http_header_timeout_s},
          {"http-idle-timeout-s", o.http_idle_timeout_s}}) {
        if (!std::isfinite(seconds) || seconds < 0.1 || seconds > 3600.0) {
            return Invalid(flag, "must be in [0.1, 3600]");
        }
    }
    for (const auto& [flag, seconds] :
         {std::pair<const char*, double>{"grpc-max-connection-age-s", o.grpc_max_connection_age_s},
          {"grpc-max-connection-age-grace-s", o.grpc_max_connection_age_grace_s}}) {
        if (!std::isfinite(seconds) || seconds < 0.0 || seconds > 86400.0 * 365) {
            return Invalid(flag, "must be in [0, 31536000]");
        }
    }
    return absl::OkStatus();
}

/// TLS, metrics, probes and credentials: secure by default.
absl::Status ValidateSecurityOptions(const ServerOptions& o) {
    if (o.tls_cert.empty() != o.tls_key.empty()) {
        return Invalid(o.tls_cert.empty() ? "tls-cert" : "tls-key",
                       "--tls-cert and --tls-key go together");
    }
    if (!o.tls_client_ca.empty() && o.tls_cert.empty()) {
        return Invalid("tls-client-ca", "needs --tls-cert and --tls-key (mTLS is TLS first)");
    }
    if (o.metrics != "open" && o.metrics != "auth" && o.metrics != "off") {
        return Invalid("metrics", absl::StrCat("'", o.metrics, "' is not open, auth or off"));
    }
    if (!o.probe_address.empty()) {
        if (absl::Status s = ValidateAddress(o.probe_address, "probe-address"); !s.ok()) return s;
    }
    // Secure by default: a listener others can reach asks for credentials, unless told not to.
    const bool credentials = !o.auth_tokens_file.empty() || !o.tls_client_ca.empty();
    if (!credentials && !o.allow_unauthenticated) {
        for (const auto& [flag, address] :
             {std::pair<const char*, const std::string&>{"grpc-address", o.grpc_address},
              {"http-address", o.http_address}}) {
            if (!IsLoopbackAddress(address)) {
                return Invalid(flag,
                               absl::StrCat(address,
                                            " listens beyond this machine and no credentials are "
                                            "asked for: give --auth-tokens-file (with --tls-cert "
                                            "and --tls-key) or --tls-client-ca, or pass "
                                            "--allow-unauthenticated to accept an open server"));
            }
        }
    }
    return absl::OkStatus();
}

}  // namespace

absl::Status ValidateOptions(const ServerOptions& o) {
    if (absl::Status s = ValidateServiceOptions(o); !s.ok()) return s;
    if (absl::Status s = ValidateConnectionOptions(o); !s.ok()) return s;
    return ValidateSecurityOptions(o);
}

bool IsLoopbackAddress(const std::string& address) {
    std::string host = address.substr(0, address.rfind(':'));
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

ServerOptions ResolveOptions(ServerOptions options) {
    if (options.cpus == 0) options.cpus = AvailableCpus();
    if (options.workers == 0) options.workers = options.cpus;
    if (options.max_queue == 0) options.max_queue = 4 * options.workers;
    if (options.http_threads == 0) options.http_threads = 2;
    return options;
}

}  // namespace soilvol::server
