// The REST gateway's exports: a list (records, loads, production) streamed as CSV or JSON lines
// from a worker, page after page, paced by the client's reading.
#include "absl/strings/str_cat.h"
#include "server/base/logging.hpp"
#include "server/handlers/export_rows.hpp"
#include "server/http/http_gateway.hpp"
#include "server/http/request_binding.hpp"

namespace soilvol::server {
namespace {

/// The lists that export, and the file name each download suggests.
const char* ExportName(const std::string& method) {
    if (method == "ListEstimates") return "soilvol-estimates";
    if (method == "ListLoads") return "soilvol-loads";
    if (method == "GetProduction") return "soilvol-production";
    return nullptr;
}

/// How long one chunk may wait for a reader that does not read.
constexpr std::chrono::seconds kStalledReader{60};

}  // namespace

absl::StatusOr<RouteMatch> HttpGateway::MatchExport(const HttpRequest& head,
                                                    ExportPath* path) const {
    std::optional<ExportPath> found = ExportPathOf(head.path, head.query);
    if (!found || head.method != "GET") return absl::NotFoundError("no export");
    absl::StatusOr<RouteMatch> match = MatchRoute(routes_, "GET", found->list_path);
    if (!match.ok() || ExportName(match->route->method) == nullptr) {
        return absl::NotFoundError(absl::StrCat(
            "'", head.path, "' exports nothing: records, loads and production export"));
    }
    *path = *std::move(found);
    return match;
}

void HttpGateway::ServeExport(const RouteMatch& match, const ExportPath& path, HttpRequest request,
                              std::shared_ptr<HttpExchange> exchange) {
    const std::string origin = request.headers.Get("Origin");
    CallContext call = ContextOf(request, match.route->method);
    const auto refuse = [&](const absl::Status& status) {
        dispatcher_.Refuse(call, status);
        exchange->Respond(ErrorResponse(status, origin));
    };
    const absl::StatusOr<ExportFormat> format = ParseExportFormat(path.format);
    if (!format.ok()) return refuse(format.status());
    const Rpc* rpc = &rpcs_.at(match.route->method);
    std::shared_ptr<google::protobuf::Message> message = rpc->new_request();
    std::string no_body;
    if (absl::Status bound =
            BindRequest(*match.route, match.fields, path.query, "", no_body, message.get());
        !bound.ok()) {
        return refuse(bound);
    }
    auto head = std::make_shared<HttpResponse>();
    const bool csv = *format == ExportFormat::kCsv;
    head->content_type = csv ? "text/csv; charset=utf-8" : "application/x-ndjson";
    head->headers.Set("Content-Disposition",
                      absl::StrCat("attachment; filename=\"", ExportName(match.route->method),
                                   csv ? ".csv\"" : ".jsonl\""));
    head->headers.Set("X-Request-Id", call.request_id);
    ApplyCors(origin, head->headers);
    auto started = std::make_shared<bool>(false);
    call.cancelled = [exchange] { return exchange->Gone(); };
    dispatcher_.Submit(
        std::move(call),
        [rpc, message, format = *format, exchange, head, started](CallRecord& record) {
            const auto write = [&](std::string chunk) {
                if (!*started && !(*started = exchange->StartStream(*head))) return false;
                return exchange->SendPaced(std::move(chunk), Clock::now() + kStalledReader);
            };
            return ExportList(*rpc, *message, format, record, write);
        },
        [this, exchange, head, started, origin](const absl::Status& status) {
            if (status.ok()) {
                if (!*started) exchange->StartStream(*head);  // nothing to write: empty
                return exchange->Finish();
            }
            // Once rows went out the status line has gone too: cut the download short.
            if (*started) return exchange->Abort();
            exchange->Respond(ErrorResponse(status, origin));
        });
}

}  // namespace soilvol::server
