// HttpGateway's checks from a request's header, before its body is read: origin (CORS),
// route, content type and encoding, credentials; and the error answers they give.
#include <algorithm>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/base/call_ids.hpp"
#include "server/base/status_map.hpp"
#include "server/http/http_gateway.hpp"
#include "server/http/multipart.hpp"
#include "server/http/request_binding.hpp"

namespace soilvol::server {
namespace {

constexpr const char* kAllowHeaders =
    "Authorization, Content-Type, Grpc-Timeout, X-Request-Id, traceparent";
constexpr const char* kExposeHeaders = "Retry-After, X-Request-Id, WWW-Authenticate";

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

/// Preflights, probes, metrics (they check their own access), the API's description and the
/// dashboard's files: answered without a token.
bool IsOpenPath(const HttpRequest& head) {
    return head.method == "OPTIONS" || head.path == "/healthz" || head.path == "/readyz" ||
           head.path == "/metrics" || head.path == "/openapi.json" || head.path == "/" ||
           head.path == "/index.html" || head.path == "/favicon.ico" ||
           absl::StartsWith(head.path, "/dashboard/");
}

/// InvalidArgument (answered 415) for a body the route does not take: its Content-Type (with
/// a hint for curl -d's form type) or a Content-Encoding.
absl::Status BodyRefused(const HttpRequest& head, const HttpRoute& route) {
    const std::string& content_type = head.headers.Get("Content-Type");
    if (HasBody(head) && !BodyAccepted(route, content_type)) {
        return absl::InvalidArgumentError(absl::StrCat(
            route.body == "*" ? "Content-Type: send application/json, "
                                "application/octet-stream (a cloud file) or "
                                "multipart/form-data (with a boundary)"
                              : "Content-Type: request bodies must be application/json",
            "; got '", content_type, "'",
            absl::StartsWithIgnoreCase(content_type, "application/x-www-form-urlencoded")
                ? " (curl -d sends it: add -H 'Content-Type: application/json')"
                : ""));
    }
    const std::string& encoding = head.headers.Get("Content-Encoding");
    if (!encoding.empty() && !absl::EqualsIgnoreCase(encoding, "identity")) {
        return absl::InvalidArgumentError(absl::StrCat(
            "Content-Encoding: '", encoding, "' is not accepted; send the body uncompressed"));
    }
    return absl::OkStatus();
}

}  // namespace

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
    if (IsOpenPath(head)) return std::nullopt;
    if (head.method == "GET" && HeightmapPngIds(head.path)) {
        CallContext call = ContextOf(head, "GetEstimate");
        if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) {
            dispatcher_.Refuse(call, allowed);
            return ErrorResponse(allowed, origin);
        }
        return std::nullopt;
    }
    ExportPath export_path;
    absl::StatusOr<RouteMatch> match = MatchExport(head, &export_path);
    if (!match.ok()) match = MatchRoute(routes_, head.method, head.path);
    if (!match.ok()) {
        // One label for every path no route serves: metrics stay bounded whatever is asked.
        CallContext call = ContextOf(head, "unmatched");
        dispatcher_.Refuse(call, match.status());
        // A wrong verb on a served path is HTTP's 405; anything else keeps its code's status.
        return ErrorResponse(match.status(), origin,
                             absl::IsUnimplemented(match.status()) ? 405 : 0);
    }
    if (absl::Status refused = BodyRefused(head, *match->route); !refused.ok()) {
        return ErrorResponse(refused, origin, 415);
    }
    CallContext call = ContextOf(head, match->route->method);
    if (absl::Status allowed = dispatcher_.Authorize(call); !allowed.ok()) {
        dispatcher_.Refuse(call, allowed);
        return ErrorResponse(allowed, origin);
    }
    return std::nullopt;
}

}  // namespace soilvol::server
