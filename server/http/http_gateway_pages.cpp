// HttpGateway's answers that are not RPCs: probes, metrics, /openapi.json, the dashboard's
// files and a record's heightmap as a PNG.
#include <string_view>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "proto/convert/proto_convert.hpp"
#include "proto/openapi_document.hpp"
#include "server/base/absl_view.hpp"
#include "server/dashboard/dashboard_files.hpp"
#include "server/http/http_gateway.hpp"
#include "server/http/query_string.hpp"

namespace soilvol::server {

bool HttpGateway::ServeDashboard(const HttpRequest& request, HttpExchange& exchange) const {
    constexpr std::string_view kPrefix = "/dashboard/";
    std::string_view name;
    if (request.path == "/favicon.ico") {  // browsers ask for it on every page: nothing here
        HttpResponse none;
        none.status = 204;
        exchange.Respond(std::move(none));
        return true;
    }
    if (request.path == "/" || request.path == "/index.html") {
        name = "index.html";
    } else if (absl::StartsWith(request.path, AbslView(kPrefix))) {
        name = std::string_view(request.path).substr(kPrefix.size());
    } else {
        return false;
    }
    for (const DashboardFile& file : DashboardFiles()) {
        if (file.name != name) continue;
        HttpResponse response;
        response.content_type = std::string(file.content_type);
        response.body = std::string(file.body);
        // The page's code and data come from this server only; the files change with it.
        response.headers.Set("Content-Security-Policy",
                             "default-src 'self'; img-src 'self' data:; style-src 'self'; "
                             "script-src 'self'; connect-src 'self'; frame-ancestors 'none'");
        response.headers.Set("X-Content-Type-Options", "nosniff");
        response.headers.Set("Cache-Control", "no-cache");
        exchange.Respond(std::move(response));
        return true;
    }
    exchange.Respond(ErrorResponse(
        absl::NotFoundError(absl::StrCat("no dashboard file '", AbslView(name), "'")), ""));
    return true;
}

bool HttpGateway::ServeOperational(const HttpRequest& request, bool probe,
                                   HttpExchange& exchange) const {
    if (request.method != "GET") return false;
    if (request.path == "/healthz") {
        exchange.Respond(JsonResponse(
            shutting_down_ ? 503 : 200,
            shutting_down_ ? R"({"status":"SHUTTING_DOWN"})" : R"({"status":"SERVING"})"));
        return true;
    }
    if (request.path == "/readyz") {
        const bool ready = !shutting_down_ && ready_();
        exchange.Respond(JsonResponse(
            ready ? 200 : 503, ready ? R"({"status":"SERVING"})" : R"({"status":"NOT_SERVING"})"));
        return true;
    }
    if (!probe && ServeDashboard(request, exchange)) return true;
    if (request.path == "/openapi.json" && !probe) {  // the API's description, not its data
        HttpResponse response = JsonResponse(200, std::string(proto::OpenApiDocument()));
        ApplyCors(request.headers.Get("Origin"), response.headers);
        exchange.Respond(std::move(response));
        return true;
    }
    if (request.path != "/metrics" || options_.metrics == MetricsAccess::kOff) return false;
    if (!probe && options_.metrics == MetricsAccess::kAuthenticated) {
        CallContext call = ContextOf(request, "ListContainers");  // the read scope
        if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) {
            exchange.Respond(ErrorResponse(allowed, request.headers.Get("Origin")));
            return true;
        }
    }
    HttpResponse response = JsonResponse(200, metrics_.Serialize());
    response.content_type = "text/plain; version=0.0.4";
    exchange.Respond(std::move(response));
    return true;
}

void HttpGateway::ServeHeightmapPng(const std::string& container_id, const std::string& estimate_id,
                                    HttpRequest request, std::shared_ptr<HttpExchange> exchange) {
    const std::string origin = request.headers.Get("Origin");
    CallContext call = ContextOf(request, "GetEstimate");
    call.cancelled = [exchange] { return exchange->Gone(); };
    int cell_px = 12;
    absl::StatusOr<std::vector<std::pair<std::string, std::string>>> query =
        ParseQuery(request.query);
    if (!query.ok()) return exchange->Respond(ErrorResponse(query.status(), origin));
    for (const auto& [name, value] : *query) {
        if ((name != "cellPx" && name != "cell_px") || !absl::SimpleAtoi(value, &cell_px) ||
            cell_px < 1 || cell_px > 64) {
            HttpResponse bad = ErrorResponse(
                absl::InvalidArgumentError("cell_px: the only parameter, 1 to 64 pixels a cell"),
                origin);
            return exchange->Respond(std::move(bad));
        }
    }
    auto png = std::make_shared<std::string>();
    const Rpc* rpc = &rpcs_.at("GetEstimate");
    dispatcher_.Submit(
        std::move(call),
        [rpc, container_id, estimate_id, cell_px, png](CallRecord& record) -> absl::Status {
            v1::GetEstimateRequest get;
            get.set_container_id(container_id);
            get.set_estimate_id(estimate_id);
            get.set_view(v1::ESTIMATE_VIEW_FULL);
            v1::Estimate estimate;
            if (absl::Status status = rpc->call(get, &estimate, record); !status.ok()) {
                return status;
            }
            absl::StatusOr<std::string> encoded = HeightmapPng(estimate.result(), cell_px);
            if (!encoded.ok()) return encoded.status();
            *png = *std::move(encoded);
            return absl::OkStatus();
        },
        [this, exchange, png, origin](const absl::Status& status) {
            if (!status.ok()) return exchange->Respond(ErrorResponse(status, origin));
            HttpResponse response;
            response.content_type = "image/png";
            response.body = std::move(*png);
            response.headers.Set("Cache-Control",
                                 "private, max-age=86400");  // records never change
            ApplyCors(origin, response.headers);
            exchange->Respond(std::move(response));
        });
}

}  // namespace soilvol::server
