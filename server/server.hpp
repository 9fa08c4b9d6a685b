#pragma once

#include <memory>

#include "absl/status/statusor.h"
#include "server/options.hpp"

namespace soilvol::server {

struct ServerParts;  ///< what a Server runs (server.cpp)

/// soilvol-server: the model store, the worker pool, the gRPC service (with health and
/// reflection) and the REST gateway, started together and stopped together.
class Server {
  public:
    /// Validates every option, opens the data directory, binds both ports and starts serving.
    /// InvalidArgument for a bad option, FailedPrecondition for an unusable data directory,
    /// Unavailable for a port that cannot be bound.
    static absl::StatusOr<std::unique_ptr<Server>> BuildAndStart(const ServerOptions& options);
    ~Server();

    int grpc_port() const;
    int http_port() const;
    int probe_port() const;  ///< 0 without --probe-address
    /// "sqlite", "postgresql" or "none": where estimate records go.
    const char* records_kind() const;
    /// Graceful stop: health goes NOT_SERVING, no new calls are accepted, calls in flight get
    /// up to shutdown_grace_s to finish. Safe to call from any thread, more than once.
    void Shutdown();
    /// Blocks until Shutdown has finished.
    void Wait();

  private:
    explicit Server(std::unique_ptr<ServerParts> parts);
    std::unique_ptr<ServerParts> parts_;
};

}  // namespace soilvol::server
