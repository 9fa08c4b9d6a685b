#include "server/http_gateway.hpp"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <future>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "httplib.h"
#include "server/status_map.hpp"

namespace soilvol::server {
namespace {

constexpr const char* kJson = "application/json";

void SendError(httplib::Response& response, const absl::Status& status, int http_status) {
    response.status = http_status;
    response.set_content(ErrorJson(status), kJson);
}

void SendError(httplib::Response& response, const absl::Status& status) {
    SendError(response, status, HttpStatusFor(status.code()));
}

/// Sets a scalar field of `message` from a path or query value.
absl::Status SetField(google::protobuf::Message* message, const std::string& name,
                      const std::string& value) {
    const google::protobuf::Descriptor* descriptor = message->GetDescriptor();
    const google::protobuf::FieldDescriptor* field = descriptor->FindFieldByName(name);
    if (field == nullptr) field = descriptor->FindFieldByCamelcaseName(name);
    if (field == nullptr || field->is_repeated() ||
        field->cpp_type() == google::protobuf::FieldDescriptor::CPPTYPE_MESSAGE) {
        return absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"));
    }
    const google::protobuf::Reflection* reflection = message->GetReflection();
    using F = google::protobuf::FieldDescriptor;
    bool ok = true;
    switch (field->cpp_type()) {
        case F::CPPTYPE_STRING: {
            if (reflection->HasField(*message, field) &&
                reflection->GetString(*message, field) != value) {
                return absl::InvalidArgumentError(absl::StrCat(
                    field->name(), ": the body says '", reflection->GetString(*message, field),
                    "' but the path says '", value, "'"));
            }
            reflection->SetString(message, field, value);
            break;
        }
        case F::CPPTYPE_BOOL: {
            ok = value == "true" || value == "false";
            if (ok) reflection->SetBool(message, field, value == "true");
            break;
        }
        case F::CPPTYPE_DOUBLE: {
            double number = 0.0;
            ok = absl::SimpleAtod(value, &number);
            if (ok) reflection->SetDouble(message, field, number);
            break;
        }
        case F::CPPTYPE_INT32: {
            int number = 0;
            ok = absl::SimpleAtoi(value, &number);
            if (ok) reflection->SetInt32(message, field, number);
            break;
        }
        default:
            return absl::InvalidArgumentError(
                absl::StrCat("parameter '", name, "' cannot be set from the URL"));
    }
    if (!ok) {
        return absl::InvalidArgumentError(
            absl::StrCat(field->name(), ": '", value, "' is not a valid value"));
    }
    return absl::OkStatus();
}

// Debian's cpp-httplib is a compiled library built with a listen backlog of 5, so a burst of
// new connections overflows the accept queue before the pool can answer 429. Linux lets a
// listening socket's backlog be raised by calling listen() again: find ours by its port.
void RaiseListenBacklog(int port) {
    for (int fd = 0; fd < 4096; ++fd) {
        int listening = 0;
        socklen_t size = sizeof(listening);
        if (getsockopt(fd, SOL_SOCKET, SO_ACCEPTCONN, &listening, &size) != 0 || !listening) {
            continue;
        }
        sockaddr_storage address{};
        socklen_t length = sizeof(address);
        if (getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length) != 0) continue;
        const int bound = address.ss_family == AF_INET6
                              ? ntohs(reinterpret_cast<sockaddr_in6*>(&address)->sin6_port)
                              : ntohs(reinterpret_cast<sockaddr_in*>(&address)->sin_port);
        if (bound == port) listen(fd, SOMAXCONN);
    }
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
                         std::vector<HttpRoute> routes, Dispatcher& dispatcher, Metrics& metrics,
                         std::function<bool()> ready)
    : options_(std::move(options)),
      rpcs_(std::move(rpcs)),
      routes_(std::move(routes)),
      dispatcher_(dispatcher),
      metrics_(metrics),
      ready_(std::move(ready)),
      server_(std::make_unique<httplib::Server>()) {}

HttpGateway::~HttpGateway() { Stop(); }

absl::StatusOr<int> HttpGateway::Start() {
    const std::size_t colon = options_.address.rfind(':');
    std::string host = options_.address.substr(0, colon);
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    int port = 0;
    if (!absl::SimpleAtoi(options_.address.substr(colon + 1), &port)) {
        return absl::InvalidArgumentError("--http-address: bad port");
    }
    const int threads = options_.threads;
    server_->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
    server_->set_payload_max_length(options_.max_body_bytes);
    server_->set_read_timeout(60, 0);
    server_->set_write_timeout(60, 0);
    const auto handler = [this](const httplib::Request& request, httplib::Response& response) {
        Handle(request, {}, response);
    };
    // Bodies are read here, counted as they arrive whatever the transfer and content encoding
    // (httplib bounds only a declared Content-Length, and inflates gzip without a bound).
    const std::size_t limit = options_.max_body_bytes;
    const auto with_body = [this, limit](const httplib::Request& request,
                                         httplib::Response& response,
                                         const httplib::ContentReader& reader) {
        std::string body;
        bool too_large = false;
        const bool read = reader([&](const char* data, std::size_t length) {
            if (length > limit - std::min(limit, body.size())) {
                too_large = true;
                return false;
            }
            body.append(data, length);
            return true;
        });
        // httplib refuses a declared Content-Length past the limit before reading any of it.
        std::uint64_t declared = 0;
        too_large =
            too_large || (!read && request.has_header("Content-Length") &&
                          absl::SimpleAtoi(request.get_header_value("Content-Length"), &declared) &&
                          declared > limit);
        if (too_large) {
            response.set_header("Connection", "close");
            SendError(response,
                      absl::ResourceExhaustedError(absl::StrCat(
                          "request body exceeds the limit of ", options_.max_body_bytes, " bytes")),
                      413);
            return;
        }
        if (!read) {
            SendError(response, absl::InvalidArgumentError("request body: could not be read"));
            return;
        }
        Handle(request, body, response);
    };
    // One router for every verb, so that unknown paths and verbs get JSON errors too.
    server_->Get(".*", handler);
    server_->Post(".*", with_body);
    server_->Put(".*", with_body);
    server_->Patch(".*", with_body);
    server_->Delete(".*", with_body);
    server_->Options(".*", handler);
    // Errors httplib raises itself (413 for oversize bodies, 400 for bad requests) get the
    // same JSON body as ours; ours already have one.
    server_->set_error_handler([this](const httplib::Request& request,
                                      httplib::Response& response) {
        if (!response.body.empty()) return;
        // httplib caps form-encoded bodies (curl -d's default type) at 8 KiB.
        const bool form = request.get_header_value("Content-Type")
                              .rfind("application/x-www-form-urlencoded", 0) == 0;
        const absl::Status status =
            response.status != 413
                ? absl::InvalidArgumentError(absl::StrCat("HTTP ", response.status))
            : form ? absl::ResourceExhaustedError(
                         "a form-encoded body is limited to 8 KiB: send the JSON with "
                         "Content-Type: application/json")
                   : absl::ResourceExhaustedError(absl::StrCat("request body exceeds the limit of ",
                                                               options_.max_body_bytes, " bytes"));
        response.set_content(ErrorJson(status), kJson);
    });
    server_->set_exception_handler(
        [](const httplib::Request&, httplib::Response& response, std::exception_ptr) {
            SendError(response, absl::InternalError("unexpected error in the HTTP gateway"));
        });
    const int bound = port == 0 ? server_->bind_to_any_port(host)
                                : (server_->bind_to_port(host, port) ? port : -1);
    if (bound < 0) {
        return absl::UnavailableError(
            absl::StrCat("--http-address: cannot listen on ", options_.address));
    }
    RaiseListenBacklog(bound);
    thread_ = std::thread([this] { server_->listen_after_bind(); });
    return bound;
}

void HttpGateway::Stop() {
    if (!thread_.joinable()) return;
    server_->stop();
    thread_.join();
}

bool HttpGateway::ApplyCors(const httplib::Request& request, httplib::Response& response) const {
    const std::string origin = request.get_header_value("Origin");
    if (origin.empty()) return false;
    const bool any = std::find(options_.cors_origins.begin(), options_.cors_origins.end(), "*") !=
                     options_.cors_origins.end();
    if (!any && std::find(options_.cors_origins.begin(), options_.cors_origins.end(), origin) ==
                    options_.cors_origins.end()) {
        return false;
    }
    response.set_header("Access-Control-Allow-Origin", any ? "*" : origin);
    response.set_header("Vary", "Origin");
    response.set_header("Access-Control-Allow-Methods", "GET, POST, DELETE, OPTIONS");
    response.set_header("Access-Control-Allow-Headers", "Content-Type, Grpc-Timeout");
    response.set_header("Access-Control-Max-Age", "600");
    return true;
}

void HttpGateway::Handle(const httplib::Request& request, const std::string& body,
                         httplib::Response& response) {
    const bool cors = ApplyCors(request, response);
    if (request.method == "OPTIONS") {
        response.status = cors ? 204 : 403;
        if (!cors) SendError(response, absl::PermissionDeniedError("origin not allowed"), 403);
        return;
    }
    // A browser sends a simple cross-origin request (text/plain POST) without asking first: one
    // from an origin not allowed is refused before it runs, and bodies must be JSON, which no
    // page can send cross-origin without the preflight above.
    // A page the server itself serves is same-origin: its Origin names this host.
    const std::string origin = request.get_header_value("Origin");
    const std::string host = request.get_header_value("Host");
    const bool same_origin =
        !host.empty() && (origin == "http://" + host || origin == "https://" + host);
    if (!origin.empty() && !cors && !same_origin) {
        SendError(response,
                  absl::PermissionDeniedError(absl::StrCat(
                      "origin '", request.get_header_value("Origin"), "' is not allowed")),
                  403);
        return;
    }
    if (!body.empty() &&
        request.get_header_value("Content-Type").rfind("application/json", 0) != 0) {
        SendError(response,
                  absl::InvalidArgumentError("Content-Type: request bodies must be "
                                             "application/json"),
                  415);
        return;
    }
    if (request.method == "GET" && request.path == "/healthz") {
        response.set_content(
            shutting_down_ ? R"({"status":"SHUTTING_DOWN"})" : R"({"status":"SERVING"})", kJson);
        response.status = shutting_down_ ? 503 : 200;
        return;
    }
    if (request.method == "GET" && request.path == "/readyz") {
        const bool ready = !shutting_down_ && ready_();
        response.status = ready ? 200 : 503;
        response.set_content(ready ? R"({"status":"SERVING"})" : R"({"status":"NOT_SERVING"})",
                             kJson);
        return;
    }
    if (request.method == "GET" && request.path == "/metrics") {
        response.set_content(metrics_.Serialize(), "text/plain; version=0.0.4");
        return;
    }
    CallContext call;
    call.transport = "http";
    call.peer = absl::StrCat(request.remote_addr, ":", request.remote_port);
    absl::StatusOr<RouteMatch> match = MatchRoute(routes_, request.method, request.path);
    if (!match.ok()) {
        // One label for every path no route serves: metrics stay bounded whatever is asked.
        call.method = "unmatched";
        dispatcher_.Refuse(call, match.status());
        // A wrong verb on a served path is HTTP's 405; anything else keeps its code's status.
        const bool not_allowed = absl::IsUnimplemented(match.status());
        if (not_allowed) {
            SendError(response, match.status(), 405);
        } else {
            SendError(response, match.status());
        }
        return;
    }
    call.method = match->route->method;
    ServeRpc(*match, request, body, response, std::move(call));
}

void HttpGateway::ServeRpc(const RouteMatch& match, const httplib::Request& request,
                           const std::string& body, httplib::Response& response, CallContext call) {
    const Rpc& rpc = rpcs_.at(match.route->method);
    std::shared_ptr<google::protobuf::Message> message = rpc.new_request();
    std::shared_ptr<google::protobuf::Message> answer = rpc.new_response();
    absl::Status parsed;
    if (match.route->body == "*" && !body.empty()) {
        google::protobuf::util::JsonParseOptions options;
        options.ignore_unknown_fields = false;
        const auto status =
            google::protobuf::util::JsonStringToMessage(body, message.get(), options);
        if (!status.ok()) {
            parsed = absl::InvalidArgumentError(
                absl::StrCat("request body: ", std::string(status.message())));
        }
    }
    for (const auto& [field, value] : match.fields) {
        if (!parsed.ok()) break;
        parsed = SetField(message.get(), field, value);
    }
    // Query parameters from the request target itself: httplib also files form-encoded bodies
    // under params, and a JSON body sent as a form must not be read as parameters.
    const std::size_t query_at = request.target.find('?');
    httplib::Params query;
    if (query_at != std::string::npos) {
        httplib::detail::parse_query_text(request.target.substr(query_at + 1), query);
    }
    for (const auto& [name, value] : query) {
        if (!parsed.ok()) break;
        parsed = match.route->body == "*"
                     ? absl::InvalidArgumentError(absl::StrCat("unknown parameter '", name, "'"))
                     : SetField(message.get(), name, value);
    }
    double timeout_ms = -1.0;
    if (parsed.ok() && request.has_header("Grpc-Timeout")) {
        absl::StatusOr<double> timeout = ParseGrpcTimeout(request.get_header_value("Grpc-Timeout"));
        parsed = timeout.status();
        if (timeout.ok()) timeout_ms = *timeout;
    }
    if (!parsed.ok()) {
        dispatcher_.Refuse(call, parsed);
        SendError(response, parsed);
        return;
    }
    if (timeout_ms >= 0.0) {
        call.deadline = call.received + std::chrono::duration_cast<Clock::duration>(
                                            std::chrono::duration<double, std::milli>(timeout_ms));
    }
    auto abandoned = std::make_shared<std::atomic<bool>>(false);
    call.cancelled = [abandoned] { return abandoned->load(); };
    auto outcome = std::make_shared<std::promise<absl::Status>>();
    std::future<absl::Status> done = outcome->get_future();
    const Clock::time_point deadline = call.deadline;
    dispatcher_.Submit(
        std::move(call),
        [&rpc, message, answer](CallRecord& record) {
            return rpc.call(*message, answer.get(), record);
        },
        [outcome](const absl::Status& status) { outcome->set_value(status); });
    if (deadline != Clock::time_point::max() &&
        done.wait_until(deadline + std::chrono::milliseconds(50)) != std::future_status::ready) {
        abandoned->store(true);
        SendError(response, absl::DeadlineExceededError("deadline expired before an answer"));
        return;
    }
    const absl::Status status = done.get();
    if (!status.ok()) {
        SendError(response, status);
        return;
    }
    google::protobuf::util::JsonPrintOptions options;
    options.always_print_primitive_fields = true;
    std::string json;
    const auto printed = google::protobuf::util::MessageToJsonString(*answer, &json, options);
    if (!printed.ok()) {
        SendError(response, absl::InternalError("response does not convert to JSON"));
        return;
    }
    response.set_content(json, kJson);
}

}  // namespace soilvol::server
