#include "server/http/http_gateway.hpp"

#include <chrono>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "server/base/logging.hpp"
#include "server/http/grpc_timeout.hpp"
#include "server/http/request_binding.hpp"
#include "server/http/sse_stream.hpp"

namespace soilvol::server {
namespace {

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

}  // namespace

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
    ExportPath export_path;
    if (absl::StatusOr<RouteMatch> list = MatchExport(request, &export_path); list.ok()) {
        return ServeExport(*list, export_path, std::move(request), std::move(exchange));
    }
    absl::StatusOr<RouteMatch> match = MatchRoute(routes_, request.method, request.path);
    if (!match.ok()) return exchange->Respond(ErrorResponse(match.status(), origin));
    if (const auto stream = streams_.find(match->route->method); stream != streams_.end()) {
        return ServeStream(stream->second, *match, std::move(request), std::move(exchange));
    }
    ServeRpc(*match, std::move(request), std::move(exchange));
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
    auto sse = std::make_shared<SseStream>(exchange, rpc.event, rpc.id_field);
    absl::StatusOr<std::function<void()>> stop = rpc.start(
        *message, [sse](const google::protobuf::Message* item) { return sse->Deliver(item); },
        [sse](const absl::Status& status) { sse->End(status); });
    if (!stop.ok()) return refuse(stop.status());
    HttpResponse head;
    head.headers.Set("X-Request-Id", call.request_id);
    ApplyCors(origin, head.headers);
    if (!sse->Start(std::move(head))) {
        (*stop)();  // the client left already; stopped outside the lock a delivery may hold
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
