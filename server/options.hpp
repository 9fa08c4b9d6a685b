#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace soilvol::server {

/// Everything soilvol-server can be told. main() fills it from flags and SOILVOL_* variables;
/// Server::BuildAndStart validates it before anything starts.
struct ServerOptions {
    /// host:port; port 0 picks a free one. Loopback by default: a server that listens beyond
    /// this machine must be given credentials to ask for (or --allow-unauthenticated).
    std::string grpc_address = "127.0.0.1:50051";
    std::string http_address = "127.0.0.1:8080";  ///< REST gateway, health and metrics
    std::string data_dir = "./data";              ///< model store
    /// Estimate records: "" = SQLite in data_dir, sqlite:<path>, postgres://..., or "none".
    std::string records_url;
    long long records_max_per_container = 10000;  ///< retention: the newest this many ...
    double records_max_age_days = 90.0;           ///< ... and none older
    /// Live estimate watches at once (WatchEstimates, the SSE route), each a stream and a few
    /// KiB; beyond, RESOURCE_EXHAUSTED (429).
    int max_watches = 2048;
    /// A watch that got nothing for this long gets a heartbeat (SSE: a comment line), which
    /// also tells a client that left from one that listens.
    double watch_heartbeat_s = 1.0;
    /// Watches are handed new records at most this often: what commits within it after a
    /// delivery waits for the next, and a watcher gets it in the same write (0: at every commit).
    double watch_coalesce_s = 0.1;
    /// Containers with their own label on /metrics' per-container figures; the rest are
    /// summed under container="_other", so that a fleet's growth cannot grow the scrape.
    int metrics_max_containers = 200;
    int workers = 0;    ///< engine threads; 0 = one per CPU available (affinity, cgroup limit)
    int max_queue = 0;  ///< requests waiting for a worker; 0 = 4 x workers
    int max_message_mb = 64;  ///< largest gRPC message; REST bodies may be 4/3 larger (base64)
    std::string log_level = "info";         ///< trace, debug, info, warn, error, critical, off
    std::string log_format = "text";        ///< text or json
    std::vector<std::string> cors_origins;  ///< allowed browser origins; "*" for any
    double shutdown_grace_s = 10.0;         ///< in-flight work gets this long on SIGTERM
    int http_threads = 0;  ///< REST I/O threads; 0 = 2 (they never wait for the engine)
    /// REST connections at once, SSE streams included (each a dashboard screen); more get
    /// 503 and close.
    int http_max_connections = 4096;
    double http_header_timeout_s = 10.0;  ///< from a request's first byte to its header's end
    double http_idle_timeout_s = 60.0;    ///< keep-alive wait for the next request
    /// A container whose struck capacity's 1-sigma exceeds this share of it carries a warning
    /// (Container.warnings), (0, 1].
    double capacity_warning_share = 0.01;
    /// An open truck load that got no pass for this long is closed; 0 = never.
    double load_idle_s = 1800.0;
    /// Production's default IANA zone and local shift starts.
    std::string site_time_zone = "UTC";
    std::vector<std::string> shift_starts = {"06:00", "18:00"};
    /// The alerts of containers without their own rules and of loads: JSON of
    /// soilvol.v1.AlertRules.
    std::string alert_rules = R"({"overloadMinProbability":0.5,"carrybackMinProbability":0.5,)"
                              R"("refusedScansInARow":3,"loadOffTarget":true})";
    /// Where alerts are posted: JSON {"webhooks": [soilvol.v1.Webhook...]}; "" = nowhere.
    std::string webhooks_file;
    /// An alert a webhook could not take for this long is abandoned (logged), (0, 720].
    double webhook_max_age_hours = 72.0;
    /// A replica sends a webhook's alerts under a lease this long, renewed at half of it: a
    /// replica that died (no graceful hand-over) is taken over after it, [10, 600].
    int webhook_lease_s = 30;
    /// PEM certificates webhooks' https servers are verified with; "" = the system's.
    std::string webhook_ca_file;

    // Security: TLS (both transports), credentials, what is open.
    std::string tls_cert;          ///< PEM certificate chain; set with tls_key: TLS on both ports
    std::string tls_key;           ///< PEM private key
    std::string tls_client_ca;     ///< set: clients must present a certificate it signed (mTLS)
    std::string auth_tokens_file;  ///< hashed bearer tokens with scopes (Authenticator)
    /// Accept a listener beyond loopback with neither tokens nor client certificates.
    bool allow_unauthenticated = false;
    bool reflection = true;        ///< gRPC server reflection
    std::string metrics = "open";  ///< /metrics: open, auth (the read scope) or off
    /// Plain-HTTP listener for probes and scrapers (/healthz, /readyz, /metrics); "" = none.
    std::string probe_address;
    double grpc_max_connection_age_s = 1800.0;      ///< then GOAWAY, so clients rebalance; 0 = none
    double grpc_max_connection_age_grace_s = 60.0;  ///< calls in flight get this long after
    /// Not a flag: the CPUs available (AvailableCpus), filled by ResolveOptions; each call's
    /// engine gets ThreadsPerCall(cpus, workers) threads.
    int cpus = 0;
};

/// host:port with a numeric port in [0, 65535]; InvalidArgument naming `flag` otherwise.
absl::Status ValidateAddress(const std::string& address, const std::string& flag);

/// InvalidArgument naming the flag and the problem for the first bad option.
absl::Status ValidateOptions(const ServerOptions& options);

/// True for 127.0.0.0/8, ::1 and localhost: a listener only this machine reaches.
bool IsLoopbackAddress(const std::string& address);

/// Options with the automatic values (workers, max_queue, http_threads, cpus) made concrete.
ServerOptions ResolveOptions(ServerOptions options);

}  // namespace soilvol::server
