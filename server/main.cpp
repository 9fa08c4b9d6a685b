// soilvol-server: flags (or SOILVOL_* variables) -> ServerOptions -> Server; SIGTERM/SIGINT
// stop it gracefully.
#include <pthread.h>
#include <sys/resource.h>

#include <csignal>
#include <cstdlib>
#include <iostream>
#include <thread>

#include "CLI/CLI.hpp"
#include "core/common/allocator.hpp"
#include "core/common/build_info.hpp"
#include "core/stereo/calibration.hpp"
#include "server/base/logging.hpp"
#include "server/dispatch/cpu_budget.hpp"
#include "server/options.hpp"
#include "server/server.hpp"

namespace {

using soilvol::server::LogEvent;
using soilvol::server::LogLevel;

/// Addresses, the data directory and the records.
void AddStorageFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--grpc-address", o.grpc_address,
                   "gRPC listen address (host:port, port 0 = any)")
        ->envname("SOILVOL_GRPC_ADDRESS")
        ->capture_default_str();
    app.add_option("--http-address", o.http_address, "REST, health and metrics listen address")
        ->envname("SOILVOL_HTTP_ADDRESS")
        ->capture_default_str();
    app.add_option("--data-dir", o.data_dir, "Directory of container models and calibrations")
        ->envname("SOILVOL_DATA_DIR")
        ->capture_default_str();
    app.add_option("--records-url", o.records_url,
                   "Where estimate records go: empty = SQLite in the data directory, "
                   "sqlite:<path>, postgres://user@host/db (replicas share it), or none")
        ->envname("SOILVOL_RECORDS_URL");
    app.add_option("--records-max-per-container", o.records_max_per_container,
                   "Records kept per container (the newest)")
        ->envname("SOILVOL_RECORDS_MAX_PER_CONTAINER")
        ->capture_default_str();
    app.add_option("--records-max-age-days", o.records_max_age_days,
                   "Records older than this are removed")
        ->envname("SOILVOL_RECORDS_MAX_AGE_DAYS")
        ->capture_default_str();
    app.add_option("--max-watches", o.max_watches,
                   "Live watches of estimates, alerts and loads together (gRPC and SSE) at "
                   "once; more get RESOURCE_EXHAUSTED / 429")
        ->envname("SOILVOL_MAX_WATCHES")
        ->capture_default_str();
    app.add_option("--watch-heartbeat-seconds", o.watch_heartbeat_s,
                   "A watch that got nothing for this long gets a heartbeat; a client that left "
                   "is noticed by it")
        ->envname("SOILVOL_WATCH_HEARTBEAT_SECONDS")
        ->capture_default_str();
    app.add_option("--watch-coalesce-seconds", o.watch_coalesce_s,
                   "Watches get new records at most this often: records committed meanwhile "
                   "wait and go to each watcher in one write (0: at every commit)")
        ->envname("SOILVOL_WATCH_COALESCE_SECONDS")
        ->capture_default_str();
    app.add_option("--metrics-max-containers", o.metrics_max_containers,
                   "Containers with a label of their own on /metrics' per-container figures; "
                   "the rest are summed as container=\"_other\"")
        ->envname("SOILVOL_METRICS_MAX_CONTAINERS")
        ->capture_default_str();
}

/// The worker pool, request sizes and registration warnings.
void AddEngineFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--workers", o.workers,
                   "Calls run at once (0 = one per CPU of the cgroup limit); each gets 2 x CPUs / "
                   "workers threads, at most the CPUs")
        ->envname("SOILVOL_WORKERS")
        ->capture_default_str();
    app.add_option(
           "--max-queue", o.max_queue,
           "Requests that may wait for a worker before RESOURCE_EXHAUSTED (0 = 4 x workers)")
        ->envname("SOILVOL_MAX_QUEUE")
        ->capture_default_str();
    app.add_option("--max-message-mb", o.max_message_mb, "Largest request [MiB]")
        ->envname("SOILVOL_MAX_MESSAGE_MB")
        ->capture_default_str();
    app.add_option("--capacity-warning-share", o.capacity_warning_share,
                   "Containers whose struck capacity's 1-sigma exceeds this share of it carry a "
                   "warning, (0, 1]")
        ->envname("SOILVOL_CAPACITY_WARNING_SHARE")
        ->capture_default_str();
    app.add_option("--load-idle-seconds", o.load_idle_s,
                   "An open truck load that got no pass for this long is closed (0 = never)")
        ->envname("SOILVOL_LOAD_IDLE_SECONDS")
        ->capture_default_str();
    app.add_option("--alert-rules", o.alert_rules,
                   "alerts of containers without their own rules, and of loads: JSON of "
                   "soilvol.v1.AlertRules ('{}': none)")
        ->envname("SOILVOL_ALERT_RULES")
        ->capture_default_str();
    app.add_option("--webhooks-file", o.webhooks_file,
                   "JSON {\"webhooks\": [soilvol.v1.Webhook...]}: where alerts are posted")
        ->envname("SOILVOL_WEBHOOKS_FILE");
    app.add_option("--webhook-max-age-hours", o.webhook_max_age_hours,
                   "an alert a webhook could not take for this long is abandoned, (0, 720]")
        ->envname("SOILVOL_WEBHOOK_MAX_AGE_HOURS")
        ->capture_default_str();
    app.add_option("--webhook-lease-seconds", o.webhook_lease_s,
                   "one replica sends a webhook's alerts under a lease this long; a replica "
                   "that died is taken over after it, [10, 600]")
        ->envname("SOILVOL_WEBHOOK_LEASE_SECONDS")
        ->capture_default_str();
    app.add_option("--webhook-ca-file", o.webhook_ca_file,
                   "PEM certificates to verify webhooks' https servers with (default: the "
                   "system's)")
        ->envname("SOILVOL_WEBHOOK_CA_FILE");
    app.add_option("--site-time-zone", o.site_time_zone,
                   "IANA time zone of production's hours, shifts and days (Europe/Berlin)")
        ->envname("SOILVOL_SITE_TIME_ZONE")
        ->capture_default_str();
    app.add_option("--shift-starts", o.shift_starts,
                   "local shift starts, comma-separated, on quarter hours (06:00,18:00)")
        ->delimiter(',')
        ->envname("SOILVOL_SHIFT_STARTS")
        ->capture_default_str();
}

/// Logging and browsers.
void AddLoggingFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error, critical, off")
        ->envname("SOILVOL_LOG_LEVEL")
        ->capture_default_str();
    app.add_option("--log-format", o.log_format, "text or json")
        ->envname("SOILVOL_LOG_FORMAT")
        ->capture_default_str();
    app.add_option("--cors-origin", o.cors_origins,
                   "Browser origin allowed to call the REST API (repeat; * for any)")
        ->envname("SOILVOL_CORS_ORIGINS")
        ->delimiter(',');
}

/// The REST listener and its limits.
void AddHttpFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--shutdown-grace-s", o.shutdown_grace_s,
                   "Seconds in-flight calls get to finish on SIGTERM")
        ->envname("SOILVOL_SHUTDOWN_GRACE_S")
        ->capture_default_str();
    app.add_option("--http-threads", o.http_threads,
                   "REST I/O threads (0 = 2; they never wait for the engine)")
        ->envname("SOILVOL_HTTP_THREADS")
        ->capture_default_str();
    app.add_option("--http-max-connections", o.http_max_connections,
                   "REST connections at once; more get 503 and are closed")
        ->envname("SOILVOL_HTTP_MAX_CONNECTIONS")
        ->capture_default_str();
    app.add_option("--http-header-timeout-s", o.http_header_timeout_s,
                   "Seconds from a request's first byte to the end of its header")
        ->envname("SOILVOL_HTTP_HEADER_TIMEOUT_S")
        ->capture_default_str();
    app.add_option("--http-idle-timeout-s", o.http_idle_timeout_s,
                   "Seconds a kept-alive REST connection may wait for its next request")
        ->envname("SOILVOL_HTTP_IDLE_TIMEOUT_S")
        ->capture_default_str();
}

/// TLS and credentials.
void AddSecurityFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--tls-cert", o.tls_cert,
                   "PEM certificate chain: TLS on the gRPC and REST ports (reloaded on change)")
        ->envname("SOILVOL_TLS_CERT");
    app.add_option("--tls-key", o.tls_key, "PEM private key of --tls-cert")
        ->envname("SOILVOL_TLS_KEY");
    app.add_option("--tls-client-ca", o.tls_client_ca,
                   "PEM CA bundle: clients must present a certificate it signed (mTLS)")
        ->envname("SOILVOL_TLS_CLIENT_CA");
    app.add_option("--auth-tokens-file", o.auth_tokens_file,
                   "Hashed bearer tokens with scopes, one per line: <name> <scopes> sha256:<hex> "
                   "(reloaded on change)")
        ->envname("SOILVOL_AUTH_TOKENS_FILE");
    app.add_flag("--allow-unauthenticated", o.allow_unauthenticated,
                 "Serve beyond loopback without asking for credentials")
        ->envname("SOILVOL_ALLOW_UNAUTHENTICATED");
}

/// Reflection, metrics, probes and gRPC connection ages.
void AddOperationsFlags(CLI::App& app, soilvol::server::ServerOptions& o) {
    app.add_option("--reflection", o.reflection, "gRPC server reflection (true or false)")
        ->envname("SOILVOL_REFLECTION")
        ->capture_default_str();
    app.add_option("--metrics", o.metrics,
                   "/metrics: open, auth (needs the read scope on the REST port) or off")
        ->envname("SOILVOL_METRICS")
        ->capture_default_str();
    app.add_option("--probe-address", o.probe_address,
                   "Plain-HTTP listener for /healthz, /readyz and /metrics (probes, scrapers)")
        ->envname("SOILVOL_PROBE_ADDRESS");
    app.add_option("--grpc-max-connection-age-s", o.grpc_max_connection_age_s,
                   "gRPC connections get GOAWAY after this long, so clients rebalance (0 = never)")
        ->envname("SOILVOL_GRPC_MAX_CONNECTION_AGE_S")
        ->capture_default_str();
    app.add_option("--grpc-max-connection-age-grace-s", o.grpc_max_connection_age_grace_s,
                   "Seconds calls in flight get after that GOAWAY")
        ->envname("SOILVOL_GRPC_MAX_CONNECTION_AGE_GRACE_S")
        ->capture_default_str();
}

soilvol::server::ServerOptions ParseFlags(CLI::App& app, int argc, char** argv) {
    soilvol::server::ServerOptions o;
    AddStorageFlags(app, o);
    AddEngineFlags(app, o);
    AddLoggingFlags(app, o);
    AddHttpFlags(app, o);
    AddSecurityFlags(app, o);
    AddOperationsFlags(app, o);
    app.parse(argc, argv);
    return o;
}

/// The log line that says the server is up: ports, security, sizes, version.
void LogListening(const soilvol::server::Server& server,
                  const soilvol::server::ServerOptions& options) {
    const soilvol::server::ServerOptions resolved = soilvol::server::ResolveOptions(options);
    LogEvent(
        LogLevel::kInfo, "listening",
        {{"grpc_port", server.grpc_port()},
         {"http_port", server.http_port()},
         {"probe_port", server.probe_port()},
         {"tls", resolved.tls_cert.empty()        ? "off"
                 : resolved.tls_client_ca.empty() ? "on"
                                                  : "mtls"},
         {"auth", !resolved.auth_tokens_file.empty() ? "tokens"
                  : !resolved.tls_client_ca.empty()  ? "client certificates"
                                                     : "none"},
         {"grpc_address", resolved.grpc_address},
         {"http_address", resolved.http_address},
         {"data_dir", resolved.data_dir},
         {"cpus", resolved.cpus},
         {"workers", resolved.workers},
         {"threads_per_call", soilvol::server::ThreadsPerCall(resolved.cpus, resolved.workers)},
         {"max_queue", resolved.max_queue},
         {"records", server.records_kind()},
         {"version", soilvol::GetBuildInfo().version},
         {"revision", soilvol::GetBuildInfo().revision}});
}

/// Every watch stream and REST connection holds a socket: the soft limit on open files (often
/// 1024) is raised to the hard one, as Go's runtime and nginx's worker_rlimit_nofile do, so
/// that --max-watches and --http-max-connections are what bound them.
void RaiseOpenFileLimit() {
    rlimit limit{};
    if (getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur >= limit.rlim_max) return;
    limit.rlim_cur = limit.rlim_max;
    setrlimit(RLIMIT_NOFILE, &limit);
}

}  // namespace

int main(int argc, char** argv) {
    soilvol::KeepFreedMemoryForReuse();
    CLI::App app{"soilvol-server: volume of soil in containers, over gRPC and REST"};
    app.set_version_flag("--version", soilvol::VersionLine("soilvol-server"));
    soilvol::server::ServerOptions options;
    try {
        options = ParseFlags(app, argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (absl::Status s = soilvol::server::ValidateOptions(options); !s.ok()) {
        std::cerr << "soilvol-server: " << s.message() << "\n";
        return 2;
    }
    if (absl::Status s = soilvol::server::ConfigureLogging(options.log_level, options.log_format);
        !s.ok()) {
        std::cerr << "soilvol-server: " << s.message() << "\n";
        return 2;
    }
    RaiseOpenFileLimit();
    // Signals go to one thread that asks the server to stop; every other thread blocks them.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    absl::StatusOr<std::unique_ptr<soilvol::server::Server>> server =
        soilvol::server::Server::BuildAndStart(options);
    if (!server.ok()) {
        LogEvent(LogLevel::kError, "cannot start", {{"error", server.status().message()}});
        return absl::IsInvalidArgument(server.status()) ? 2 : 1;
    }
    LogListening(**server, options);
    std::thread waiter([&server, &signals] {
        int signal = 0;
        sigwait(&signals, &signal);
        LogEvent(LogLevel::kInfo, "signal", {{"signal", signal == SIGTERM ? "SIGTERM" : "SIGINT"}});
        (*server)->Shutdown();
    });
    (*server)->Wait();
    waiter.join();
    if (const int searches = soilvol::stereo::AbandonedBoardSearches(); searches > 0) {
        // A stopped calibration's board search still runs in OpenCV: end without the static
        // destructors it may still need.
        LogEvent(LogLevel::kInfo, "exiting past abandoned board searches",
                 {{"searches", searches}});
        std::_Exit(0);
    }
    return 0;
}
