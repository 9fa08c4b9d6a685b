#pragma once

#include <string>
#include <vector>

#include "absl/status/status.h"

namespace soilvol::server {

/// Everything soilvol-server can be told. main() fills it from flags and SOILVOL_* variables;
/// Server::BuildAndStart validates it before anything starts.
struct ServerOptions {
    std::string grpc_address = "0.0.0.0:50051";  ///< host:port; port 0 picks a free one
    std::string http_address = "0.0.0.0:8080";   ///< REST gateway, health and metrics
    std::string data_dir = "./data";             ///< model store
    int workers = 0;    ///< engine threads; 0 = one per CPU available (affinity, cgroup limit)
    int max_queue = 0;  ///< requests waiting for a worker; 0 = 4 x workers
    int max_message_mb = 64;  ///< largest gRPC message; REST bodies may be 4/3 larger (base64)
    std::string log_level = "info";         ///< trace, debug, info, warn, error, critical, off
    std::string log_format = "text";        ///< text or json
    std::vector<std::string> cors_origins;  ///< allowed browser origins; "*" for any
    double shutdown_grace_s = 10.0;         ///< in-flight work gets this long on SIGTERM
    /// REST connections served at once; 0 = 2 x (workers + max_queue) + 4, so that a full
    /// pool is what refuses REST calls (429), not a connection backlog.
    int http_threads = 0;
    /// Not a flag: the CPUs available (AvailableCpus), filled by ResolveOptions; each call's
    /// engine gets ThreadsPerCall(cpus, workers) threads.
    int cpus = 0;
};

/// host:port with a numeric port in [0, 65535]; InvalidArgument naming `flag` otherwise.
absl::Status ValidateAddress(const std::string& address, const std::string& flag);

/// InvalidArgument naming the flag and the problem for the first bad option.
absl::Status ValidateOptions(const ServerOptions& options);

/// Options with the automatic values (workers, max_queue, http_threads, cpus) made concrete.
ServerOptions ResolveOptions(ServerOptions options);

}  // namespace soilvol::server
