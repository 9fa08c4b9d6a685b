#pragma once

#include <atomic>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/dispatch/dispatcher.hpp"
#include "server/dispatch/metrics.hpp"
#include "server/handlers/rpc_table.hpp"
#include "server/http/http_routes.hpp"
#include "server/http/http_server.hpp"

namespace soilvol::server {

/// Who may read /metrics.
enum class MetricsAccess { kOpen, kAuthenticated, kOff };

struct HttpGatewayOptions {
    HttpServerOptions server;               ///< address, I/O threads, limits, TLS
    std::vector<std::string> cors_origins;  ///< allowed Origin values; "*" allows any
    MetricsAccess metrics = MetricsAccess::kOpen;
    /// Set: a second, plain-HTTP listener serving only /healthz, /readyz and (unless off)
    /// /metrics, for kubelet probes and scrapers that present no certificate or token.
    std::string probe_address;
};

/// The REST/JSON face of soilvol.v1.SoilVolume, routed from the proto's google.api.http
/// annotations: JSON in (proto3 mapping, unknown fields refused), the same handlers as gRPC
/// through the same Dispatcher, JSON out; errors as {code, message, details}. Origin, content
/// type, route and credentials are checked from the header, before a body is read. Also
/// /healthz (live), /readyz (ready) and /metrics (Prometheus text).
class HttpGateway {
  public:
    /// `streams`: the server-streaming RPCs, served as Server-Sent Events.
    HttpGateway(HttpGatewayOptions options, std::map<std::string, Rpc> rpcs,
                std::map<std::string, StreamRpc> streams, std::vector<HttpRoute> routes,
                Dispatcher& dispatcher, Metrics& metrics, std::function<bool()> ready);
    ~HttpGateway();

    /// Binds and serves; the bound REST port. Unavailable when an address cannot be bound,
    /// InvalidArgument for unusable TLS files.
    absl::StatusOr<int> Start();
    /// The probe listener's port, 0 when there is none.
    int probe_port() const { return probe_port_; }
    /// Stops accepting and closes the connections.
    void Stop();
    /// From now on /readyz answers 503 and responses close their connection.
    void BeginShutdown() { shutting_down_ = true; }
    const HttpConnectionStats& stats() const { return server_->stats(); }

  private:
    std::optional<HttpResponse> Admit(const HttpRequest& head) const;
    void Handle(HttpRequest request, std::shared_ptr<HttpExchange> exchange);
    /// GET /v1/containers/{container_id}/estimates/{estimate_id}/heightmap.png[?cellPx=N]: a
    /// record's heightmap as a colour map, for embedding elsewhere (the read scope, as
    /// GetEstimate). Rendered on a worker.
    void ServeHeightmapPng(const std::string& container_id, const std::string& estimate_id,
                           HttpRequest request, std::shared_ptr<HttpExchange> exchange);
    /// GET /v1/containers/{id}/estimates:export, /v1/loads:export, /v1/production:export: the
    /// list route an export path names (ExportPathOf), set in `path`; NotFound otherwise.
    absl::StatusOr<RouteMatch> MatchExport(const HttpRequest& head, ExportPath* path) const;
    /// The list's items as CSV or JSON lines (ExportList), streamed from a worker at the
    /// client's pace (the list's scope, filters and errors); a failure after the first rows
    /// cuts the download short.
    void ServeExport(const RouteMatch& match, const ExportPath& path, HttpRequest request,
                     std::shared_ptr<HttpExchange> exchange);
    /// The dashboard's files at / and /dashboard/<name>; false for other paths.
    bool ServeDashboard(const HttpRequest& request, HttpExchange& exchange) const;
    /// Health and metrics; false when `request` is not for them.
    bool ServeOperational(const HttpRequest& request, bool probe, HttpExchange& exchange) const;
    void ServeRpc(const RouteMatch& match, HttpRequest request,
                  std::shared_ptr<HttpExchange> exchange);
    /// A server-streaming RPC as Server-Sent Events: `event: <name>`, `id:` the message's
    /// id field, `data:` its JSON; Last-Event-ID resumes; comments as heartbeats; an `error`
    /// event (a google.rpc.Status) when the server ends the stream.
    void ServeStream(const StreamRpc& rpc, const RouteMatch& match, HttpRequest request,
                     std::shared_ptr<HttpExchange> exchange);
    /// The request's call as the dispatcher sees it (method, peer, credentials).
    CallContext ContextOf(const HttpRequest& request, const std::string& method) const;
    /// CORS headers for an allowed origin; false when the Origin is absent or not allowed.
    bool ApplyCors(const std::string& origin, HttpHeaders& headers) const;
    bool OriginRefused(const HttpRequest& request) const;
    /// An error answer with the CORS headers of `origin` (and WWW-Authenticate for 401/403).
    HttpResponse ErrorResponse(const absl::Status& status, const std::string& origin,
                               int http_status = 0) const;

    HttpGatewayOptions options_;
    std::map<std::string, Rpc> rpcs_;
    std::map<std::string, StreamRpc> streams_;
    std::vector<HttpRoute> routes_;
    Dispatcher& dispatcher_;
    Metrics& metrics_;
    std::function<bool()> ready_;
    std::atomic<bool> shutting_down_{false};
    std::unique_ptr<HttpServer> server_;
    std::unique_ptr<HttpServer> probe_;
    int probe_port_ = 0;
};

}  // namespace soilvol::server
