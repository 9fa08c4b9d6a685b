#include "server/http_gateway.hpp"

#include <algorithm>
#include <chrono>
#include <mutex>
#include <regex>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "google/protobuf/util/json_util.h"
#include "proto/openapi_document.hpp"
#include "server/call_ids.hpp"
#include "server/dashboard_files.hpp"
#include "server/logging.hpp"
#include "server/multipart.hpp"
#include "server/proto_convert.hpp"
#include "server/status_map.hpp"
#include "server/store/absl_view.hpp"

namespace soilvol::server {
namespace {

constexpr const char* kAllowHeaders =
    "Authorization, Content-Type, Grpc-Timeout, X-Request-Id, traceparent";
constexpr const char* kExposeHeaders = "Retry-After, X-Request-Id, WWW-Authenticate";

/// What one REST call carries to its worker: the request as read, the messages, the JSON out.
struct RestCall {
    const Rpc* rpc = nullptr;
    const HttpRoute* route = nullptr;
    std::map<std::string, std::string> path_fields;
    HttpRequest request;
    std::string json;
};

absl::Status ToJson(const google::protobuf::Message& answer, std::string* json) {
    google::protobuf::util::JsonPrintOptions options;
    options.always_print_primitive_fields = true;
    if (!google::protobuf::util::MessageToJsonString(answer, json, options).ok()) {
        return absl::InternalError("response does not convert to JSON");
    }
    return absl::OkStatus();
}

// The request message from the body, the path and the query; the handler; the answer as
// JSON. Runs on a worker, and the conversion after the handler's late step if it has one.
absl::Status BindAndCall(RestCall& call, CallRecord& record) {
    std::unique_ptr<google::protobuf::Message> message = call.rpc->new_request();
    if (absl::Status bound =
            BindRequest(*call.route, call.path_fields, call.request.query,
                        call.request.headers.Get("Content-Type"), call.request.body, message.get());
        !bound.ok()) {
        return bound;
    }
    std::string().swap(call.request.body);  // its bytes are in the message now
    std::shared_ptr<google::protobuf::Message> answer(call.rpc->new_response());
    if (absl::Status status = call.rpc->call(*message, answer.get(), record); !status.ok()) {
        return status;
    }
    if (!record.finish_later) return ToJson(*answer, &call.json);
    // `call` lives as long as the call: the dispatcher keeps it until the completion ran.
    record.finish_later = [late = std::move(record.finish_later), answer,
                           json = &call.json](std::function<void(absl::Status)> finish) {
        late([answer, json, finish = std::move(finish)](absl::Status status) {
            if (status.ok()) status = ToJson(*answer, json);
            finish(status);
        });
    };
    return absl::OkStatus();
}

HttpResponse JsonResponse(int status, std::string body) {
    HttpResponse response;
    response.status = status;
    response.body = std::move(body);
    return response;
}

/// The ids of a heightmap.png path; nullopt for any other path.
std::optional<std::pair<std::string, std::string>> HeightmapPngIds(const std::string& path) {
    static const std::regex kPath(R"(^/v1/containers/([^/:]+)/estimates/([^/:]+)/heightmap\.png$)");
    std::smatch groups;
    if (!std::regex_match(path, groups, kPath)) return std::nullopt;
    return std::make_pair(groups[1].str(), groups[2].str());
}

/// JSON everywhere; a binary or multipart body where the route takes the whole request.
bool BodyAccepted(const HttpRoute& route, const std::string& content_type) {
    switch (BodyKindOf(content_type)) {
        case BodyKind::kJson:
            return true;
        case BodyKind::kBinary:
            return route.body == "*";
        case BodyKind::kMultipart:
            return route.body == "*" && MultipartBoundary(content_type).ok();
        case BodyKind::kOther:
            return false;
    }
    return false;
}

bool HasBody(const HttpRequest& head) {
    return head.chunked || head.content_length.value_or(0) > 0;
}

}  // namespace

absl::StatusOr<double> ParseGrpcTimeout(const std::string& value) {
    if (value.size() < 2 || value.size() > 9) {
        return absl::InvalidArgumentError(
            absl::StrCat("Grpc-Timeout: '", value, "' is not 1-8 digits and a unit"));
    }
    long long amount = 0;
    const std::string digits = value.substr(0, value.size() - 1);
    if (!std::all_of(digits.begin(), digits.end(), ::isdigit) ||
        !absl::SimpleAtoi(digits, &amount)) {
        return absl::InvalidArgumentError(
            absl::StrCat("Grpc-Timeout: '", value, "' does not start with digits"));
    }
    const auto amount_d = static_cast<double>(amount);
    double ms = 0.0;
    switch (value.back()) {
        case 'H':
            ms = amount_d * 3600e3;
            break;
        case 'M':
            ms = amount_d * 60e3;
            break;
        case 'S':
            ms = amount_d * 1e3;
            break;
        case 'm':
            ms = amount_d;
            break;
        case 'u':
            ms = amount_d * 1e-3;
            break;
        case 'n':
            ms = amount_d * 1e-6;
            break;
        default:
            return absl::InvalidArgumentError(absl::StrCat("Grpc-Timeout: unit '",
                                                           std::string(1, value.back()),
                                                           "' is not one of H, M, S, m, u, n"));
    }
    // A clock of nanoseconds overflows past 292 years; no call needs more than a day.
    constexpr double kDayMs = 86400e3;
    return std::min(ms, kDayMs);
}

HttpGateway::HttpGateway(HttpGatewayOptions options, std::map<std::string, Rpc> rpcs,
                         std::map<std::string, StreamRpc> streams, std::vector<HttpRoute> routes,
                         Dispatcher& dispatcher, Metrics& metrics, std::function<bool()> ready)
    : options_(std::move(options)),
      rpcs_(std::move(rpcs)),
      streams_(std::move(streams)),
      routes_(std::move(routes)),
      dispatcher_(dispatcher),
      metrics_(metrics),
      ready_(std::move(ready)) {
    server_ = std::make_unique<HttpServer>(
        options_.server, [this](const HttpRequest& head) { return Admit(head); },
        [this](HttpRequest request, std::shared_ptr<HttpExchange> exchange) {
            Handle(std::move(request), std::move(exchange));
        });
    if (!options_.probe_address.empty()) {
        HttpServerOptions probe;
        probe.address = options_.probe_address;
        probe.io_threads = 1;
        probe.limits.max_connections = 64;
        probe.limits.max_body_bytes = 0;
        probe_ = std::make_unique<HttpServer>(
            probe, [](const HttpRequest&) { return std::optional<HttpResponse>(); },
            [this](HttpRequest request, std::shared_ptr<HttpExchange> exchange) {
                if (!ServeOperational(request, true, *exchange)) {
                    exchange->Respond(ErrorResponse(
                        absl::NotFoundError("the probe listener serves /healthz, /readyz and "
                                            "/metrics only"),
                        ""));
                }
            });
    }
}

HttpGateway::~HttpGateway() { Stop(); }

absl::StatusOr<int> HttpGateway::Start() {
    absl::StatusOr<int> port = server_->Start();
    if (!port.ok()) {
        return absl::Status(port.status().code(),
                            absl::StrCat("--http-address: ", port.status().message()));
    }
    if (probe_ != nullptr) {
        absl::StatusOr<int> probe_port = probe_->Start();
        if (!probe_port.ok()) {
            server_->Stop();
            return absl::Status(probe_port.status().code(),
                                absl::StrCat("--probe-address: ", probe_port.status().message()));
        }
        probe_port_ = *probe_port;
    }
    return port;
}

void HttpGateway::Stop() {
    if (probe_ != nullptr) probe_->Stop();
    server_->Stop();
}

bool HttpGateway::ApplyCors(const std::string& origin, HttpHeaders& headers) const {
    if (origin.empty()) return false;
    const auto& allowed = options_.cors_origins;
    const bool any = std::find(allowed.begin(), allowed.end(), "*") != allowed.end();
    if (!any && std::find(allowed.begin(), allowed.end(), origin) == allowed.end()) return false;
    headers.Set("Access-Control-Allow-Origin", any ? "*" : origin);
    headers.Set("Vary", "Origin");
    headers.Set("Access-Control-Allow-Methods", "GET, POST, PUT, PATCH, DELETE, OPTIONS");
    headers.Set("Access-Control-Allow-Headers", kAllowHeaders);
    headers.Set("Access-Control-Expose-Headers", kExposeHeaders);
    headers.Set("Access-Control-Max-Age", "600");
    return true;
}

// A browser sends a simple cross-origin request (a text/plain POST) without asking first: one
// from an origin not allowed is refused before it runs. A page the server itself serves is
// same-origin: its Origin names this host.
bool HttpGateway::OriginRefused(const HttpRequest& request) const {
    const std::string& origin = request.headers.Get("Origin");
    if (origin.empty()) return false;
    HttpHeaders ignored;
    if (ApplyCors(origin, ignored)) return false;
    const std::string& host = request.headers.Get("Host");
    return host.empty() || (origin != "http://" + host && origin != "https://" + host);
}

HttpResponse HttpGateway::ErrorResponse(const absl::Status& status, const std::string& origin,
                                        int http_status) const {
    HttpResponse response = JsonResponse(
        http_status > 0 ? http_status : HttpStatusFor(status.code()), ErrorJson(status));
    ApplyCors(origin, response.headers);
    if (status.code() == absl::StatusCode::kUnauthenticated) {
        response.headers.Set("WWW-Authenticate", R"(Bearer realm="soilvol")");
    } else if (status.code() == absl::StatusCode::kPermissionDenied) {
        response.headers.Set("WWW-Authenticate",
                             R"(Bearer realm="soilvol", error="insufficient_scope")");
    } else if (const int seconds = RetryAfterSeconds(status); seconds > 0) {
        response.headers.Set("Retry-After", std::to_string(seconds));
    }
    if (shutting_down_) response.headers.Set("Connection", "close");
    return response;
}

CallContext HttpGateway::ContextOf(const HttpRequest& request, const std::string& method) const {
    CallContext call;
    call.method = method;
    call.transport = "http";
    call.peer = request.peer;
    call.authorization = request.headers.Get("Authorization");
    call.tls_identity = request.tls_identity;
    call.request_id = RequestIdOf(request.headers.Get("X-Request-Id"));
    call.trace_id = TraceIdOf(request.headers.Get("traceparent"));
    return call;
}

std::optional<HttpResponse> HttpGateway::Admit(const HttpRequest& head) const {
    const std::string& origin = head.headers.Get("Origin");
    if (OriginRefused(head)) {
        return ErrorResponse(
            absl::PermissionDeniedError(absl::StrCat("origin '", origin, "' is not allowed")),
            origin);
    }
    if (head.method == "OPTIONS" || head.path == "/healthz" || head.path == "/readyz" ||
        head.path == "/metrics" || head.path == "/openapi.json" || head.path == "/" ||
        head.path == "/index.html" || head.path == "/favicon.ico" ||
        absl::StartsWith(head.path, "/dashboard/")) {
        return std::nullopt;
    }
    if (head.method == "GET" && HeightmapPngIds(head.path)) {
        CallContext call = ContextOf(head, "GetEstimate");
        if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) {
            dispatcher_.Refuse(call, allowed);
            return ErrorResponse(allowed, origin);
        }
        return std::nullopt;
    }
    absl::StatusOr<RouteMatch> match = MatchRoute(routes_, head.method, head.path);
    if (!match.ok()) {
        // One label for every path no route serves: metrics stay bounded whatever is asked.
        CallContext call = ContextOf(head, "unmatched");
        dispatcher_.Refuse(call, match.status());
        // A wrong verb on a served path is HTTP's 405; anything else keeps its code's status.
        return ErrorResponse(match.status(), origin,
                             absl::IsUnimplemented(match.status()) ? 405 : 0);
    }
    const std::string& content_type = head.headers.Get("Content-Type");
    if (HasBody(head) && !BodyAccepted(*match->route, content_type)) {
        return ErrorResponse(
            absl::InvalidArgumentError(absl::StrCat(
                match->route->body == "*" ? "Content-Type: send application/json, "
                                            "application/octet-stream (a cloud file) or "
                                            "multipart/form-data (with a boundary)"
                                          : "Content-Type: request bodies must be application/json",
                "; got '", content_type, "'",
                absl::StartsWithIgnoreCase(content_type, "application/x-www-form-urlencoded")
                    ? " (curl -d sends it: add -H 'Content-Type: "
                      "application/json')"
                    : "")),
            origin, 415);
    }
    const std::string& encoding = head.headers.Get("Content-Encoding");
    if (!encoding.empty() && !absl::EqualsIgnoreCase(encoding, "identity")) {
        return ErrorResponse(
            absl::InvalidArgumentError(absl::StrCat("Content-Encoding: '", encoding,
                                                    "' is not accepted; send the "
                                                    "body uncompressed")),
            origin, 415);
    }
    CallContext call = ContextOf(head, match->route->method);
    if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) {
        dispatcher_.Refuse(call, allowed);
        return ErrorResponse(allowed, origin);
    }
    return std::nullopt;
}

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

void HttpGateway::Handle(HttpRequest request, std::shared_ptr<HttpExchange> exchange) {
    const std::string origin = request.headers.Get("Origin");
    if (request.method == "OPTIONS") {
        HttpResponse response;
        response.status = 204;
        if (!ApplyCors(origin, response.headers)) {
            response = ErrorResponse(absl::PermissionDeniedError("origin not allowed"), origin);
        }
        return exchange->Respond(std::move(response));
    }
    if (ServeOperational(request, false, *exchange)) return;
    if (const auto png = HeightmapPngIds(request.path); png && request.method == "GET") {
        return ServeHeightmapPng(png->first, png->second, std::move(request), std::move(exchange));
    }
    absl::StatusOr<RouteMatch> match = MatchRoute(routes_, request.method, request.path);
    if (!match.ok()) return exchange->Respond(ErrorResponse(match.status(), origin));
    if (const auto stream = streams_.find(match->route->method); stream != streams_.end()) {
        return ServeStream(stream->second, *match, std::move(request), std::move(exchange));
    }
    ServeRpc(*match, std::move(request), std::move(exchange));
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

void HttpGateway::ServeStream(const StreamRpc& rpc, const RouteMatch& match, HttpRequest request,
                              std::shared_ptr<HttpExchange> exchange) {
    const std::string origin = request.headers.Get("Origin");
    CallContext call = ContextOf(request, match.route->method);
    const auto refuse = [&](const absl::Status& status) {
        dispatcher_.Refuse(call, status);
        HttpResponse response = ErrorResponse(status, origin);
        response.headers.Set("X-Request-Id", call.request_id);
        exchange->Respond(std::move(response));
    };
    if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) return refuse(allowed);
    std::unique_ptr<google::protobuf::Message> message = rpc.new_request();
    if (absl::Status bound =
            BindRequest(*match.route, match.fields, request.query,
                        request.headers.Get("Content-Type"), request.body, message.get());
        !bound.ok()) {
        return refuse(bound);
    }
    // An EventSource reconnecting sends the last id it saw: resume after it.
    const std::string& last_event_id = request.headers.Get("Last-Event-ID");
    const google::protobuf::FieldDescriptor* resume =
        message->GetDescriptor()->FindFieldByName(rpc.resume_field);
    if (!last_event_id.empty() && resume != nullptr &&
        message->GetReflection()->GetString(*message, resume).empty()) {
        message->GetReflection()->SetString(message.get(), resume, last_event_id);
    }
    // Records may arrive before the head is sent: they wait in `pending` until it is.
    struct Sse {
        std::mutex mutex;
        bool started = false;
        std::vector<std::string> pending;
    };
    auto sse = std::make_shared<Sse>();
    const std::string id_field = rpc.id_field;
    const auto send = [sse, exchange](std::string chunk) {
        std::lock_guard<std::mutex> lock(sse->mutex);
        if (!sse->started) {
            sse->pending.push_back(std::move(chunk));
            return true;
        }
        return exchange->Send(std::move(chunk));
    };
    auto deliver = [send, id_field](const google::protobuf::Message* item) {
        if (item == nullptr) return send(": keepalive\n\n");
        std::string json;
        if (!google::protobuf::util::MessageToJsonString(*item, &json).ok()) return true;
        const google::protobuf::FieldDescriptor* id =
            item->GetDescriptor()->FindFieldByName(id_field);
        const std::string event_id =
            id != nullptr ? item->GetReflection()->GetString(*item, id) : "";
        return send(absl::StrCat("id: ", event_id, "\nevent: estimate\ndata: ", json, "\n\n"));
    };
    auto ended = [sse, exchange](const absl::Status& status) {
        std::lock_guard<std::mutex> lock(sse->mutex);
        exchange->Send(absl::StrCat("event: error\ndata: ", ErrorJson(status), "\n\n"));
        exchange->Finish();
    };
    absl::StatusOr<std::function<void()>> stop =
        rpc.start(*message, std::move(deliver), std::move(ended));
    if (!stop.ok()) return refuse(stop.status());
    HttpResponse head;
    head.content_type = "text/event-stream";
    head.headers.Set("Cache-Control", "no-cache");
    head.headers.Set("X-Accel-Buffering", "no");  // proxies: pass each event on at once
    head.headers.Set("X-Request-Id", call.request_id);
    ApplyCors(origin, head.headers);
    bool started = false;
    {
        std::lock_guard<std::mutex> lock(sse->mutex);
        started = exchange->StartStream(std::move(head));
        if (started) {
            sse->started = true;
            // The retry hint, then what arrived meanwhile.
            exchange->Send("retry: 1000\n: watching\n\n");
            for (std::string& chunk : sse->pending) exchange->Send(std::move(chunk));
            sse->pending.clear();
        }
    }
    if (!started) {  // the client left already; stopped outside the lock a delivery may hold
        (*stop)();
        return;
    }
    LogEvent(LogLevel::kInfo, "watch started",
             {{"method", call.method}, {"request_id", call.request_id}, {"peer", call.peer}});
}

void HttpGateway::ServeRpc(const RouteMatch& match, HttpRequest request,
                           std::shared_ptr<HttpExchange> exchange) {
    const std::string origin = request.headers.Get("Origin");
    CallContext call = ContextOf(request, match.route->method);
    const std::string request_id = call.request_id;
    // Every answer names the call's request id, as the log line does.
    const auto tagged = [request_id](HttpResponse response) {
        response.headers.Set("X-Request-Id", request_id);
        return response;
    };
    if (request.headers.Has("Grpc-Timeout")) {
        absl::StatusOr<double> ms = ParseGrpcTimeout(request.headers.Get("Grpc-Timeout"));
        if (!ms.ok()) {
            dispatcher_.Refuse(call, ms.status());
            return exchange->Respond(tagged(ErrorResponse(ms.status(), origin)));
        }
        call.deadline = call.received + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double, std::milli>(*ms));
        // The caller hears of its deadline on time even when its call still waits for a worker.
        exchange->RespondBy(
            call.deadline + std::chrono::milliseconds(50),
            tagged(ErrorResponse(absl::DeadlineExceededError("deadline expired before an answer"),
                                 origin)));
    }
    call.cancelled = [exchange] { return exchange->Gone(); };
    auto rest = std::make_shared<RestCall>(RestCall{
        &rpcs_.at(match.route->method), match.route, match.fields, std::move(request), {}});
    dispatcher_.Submit(
        std::move(call), [rest](CallRecord& record) { return BindAndCall(*rest, record); },
        [this, rest, exchange, origin, tagged](const absl::Status& status) {
            if (!status.ok()) return exchange->Respond(tagged(ErrorResponse(status, origin)));
            HttpResponse response = JsonResponse(200, std::move(rest->json));
            ApplyCors(origin, response.headers);
            if (shutting_down_) response.headers.Set("Connection", "close");
            exchange->Respond(tagged(std::move(response)));
        });
}

}  // namespace soilvol::server
