#include "server/http/connection_state.hpp"

#include <string>

#include "server/base/status_map.hpp"

namespace soilvol::server::http_detail {

HttpResponse ErrorResponse(int status, const absl::Status& error) {
    HttpResponse response;
    response.status = status;
    response.body = ErrorJson(error);
    if (const int seconds = RetryAfterSeconds(error); seconds > 0) {
        response.headers.Set("Retry-After", std::to_string(seconds));
    }
    return response;
}

HttpResponse ErrorResponse(int status, absl::StatusCode code, const std::string& message) {
    absl::Status error(code, message);
    // Too large stays too large: no retry hint.
    if (status == 413) error = WithReason(std::move(error), kReasonTooLarge);
    return ErrorResponse(status, error);
}

HttpResponse UploadBudgetFull() {
    return ErrorResponse(
        429,
        WithReason(absl::ResourceExhaustedError("server busy receiving other uploads; retry later"),
                   "UPLOAD_BUDGET_FULL"));
}

}  // namespace soilvol::server::http_detail
