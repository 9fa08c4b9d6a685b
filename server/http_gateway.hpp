#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "server/dispatcher.hpp"
#include "server/http_routes.hpp"
#include "server/metrics.hpp"
#include "server/rpc_table.hpp"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace soilvol::server {

struct HttpGatewayOptions {
    std::string address = "0.0.0.0:8080";   ///< host:port; port 0 picks a free one
    std::size_t max_body_bytes = 0;         ///< larger bodies get 413
    std::vector<std::string> cors_origins;  ///< allowed Origin values; "*" allows any
    int threads = 8;
};

/// The REST/JSON face of soilvol.v1.SoilVolume (cpp-httplib), routed from the proto's
/// google.api.http annotations: JSON in (proto3 mapping, unknown fields refused), the same
/// handlers as gRPC through the same Dispatcher, JSON out; errors as {code, message, details}.
/// Also /healthz (live), /readyz (ready) and /metrics (Prometheus text).
class HttpGateway {
  public:
    HttpGateway(HttpGatewayOptions options, std::map<std::string, Rpc> rpcs,
                std::vector<HttpRoute> routes, Dispatcher& dispatcher, Metrics& metrics,
                std::function<bool()> ready);
    ~HttpGateway();

    /// Binds and serves on a thread of its own. Unavailable when the address cannot be bound.
    absl::StatusOr<int> Start();
    /// Stops accepting and waits for the serving thread.
    void Stop();
    /// From now on /readyz answers 503.
    void BeginShutdown() { shutting_down_ = true; }

  private:
    /// `body`: the request body as read within the limit (httplib's own request.body is not
    /// used: it bounds neither chunked nor compressed bodies).
    void Handle(const httplib::Request& request, const std::string& body,
                httplib::Response& response);
    void ServeRpc(const RouteMatch& match, const httplib::Request& request, const std::string& body,
                  httplib::Response& response, CallContext call);
    bool ApplyCors(const httplib::Request& request, httplib::Response& response) const;

    HttpGatewayOptions options_;
    std::map<std::string, Rpc> rpcs_;
    std::vector<HttpRoute> routes_;
    Dispatcher& dispatcher_;
    Metrics& metrics_;
    std::function<bool()> ready_;
    std::atomic<bool> shutting_down_{false};
    std::unique_ptr<httplib::Server> server_;
    std::thread thread_;
};

/// A Grpc-Timeout header value ("10S", "500m", "2M", "1H", "250u", "100n") in milliseconds;
/// anything beyond a day (up to 99999999H) is read as a day.
absl::StatusOr<double> ParseGrpcTimeout(const std::string& value);

}  // namespace soilvol::server
