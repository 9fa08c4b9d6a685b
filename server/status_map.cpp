#include "server/status_map.hpp"

#include <cstdio>

#include "absl/strings/str_cat.h"

namespace soilvol::server {

int HttpStatusFor(absl::StatusCode code) {
    switch (code) {
        case absl::StatusCode::kOk:
            return 200;
        case absl::StatusCode::kCancelled:
            return 499;
        case absl::StatusCode::kInvalidArgument:
            return 400;
        case absl::StatusCode::kFailedPrecondition:
            return 400;
        case absl::StatusCode::kOutOfRange:
            return 400;
        case absl::StatusCode::kDeadlineExceeded:
            return 504;
        case absl::StatusCode::kNotFound:
            return 404;
        case absl::StatusCode::kAlreadyExists:
            return 409;
        case absl::StatusCode::kAborted:
            return 409;
        case absl::StatusCode::kPermissionDenied:
            return 403;
        case absl::StatusCode::kUnauthenticated:
            return 401;
        case absl::StatusCode::kResourceExhausted:
            return 429;
        case absl::StatusCode::kUnimplemented:
            return 501;
        case absl::StatusCode::kUnavailable:
            return 503;
        default:
            return 500;  // UNKNOWN, INTERNAL, DATA_LOSS
    }
}

std::string_view CodeName(absl::StatusCode code) {
    switch (code) {
        case absl::StatusCode::kOk:
            return "OK";
        case absl::StatusCode::kCancelled:
            return "CANCELLED";
        case absl::StatusCode::kUnknown:
            return "UNKNOWN";
        case absl::StatusCode::kInvalidArgument:
            return "INVALID_ARGUMENT";
        case absl::StatusCode::kDeadlineExceeded:
            return "DEADLINE_EXCEEDED";
        case absl::StatusCode::kNotFound:
            return "NOT_FOUND";
        case absl::StatusCode::kAlreadyExists:
            return "ALREADY_EXISTS";
        case absl::StatusCode::kPermissionDenied:
            return "PERMISSION_DENIED";
        case absl::StatusCode::kResourceExhausted:
            return "RESOURCE_EXHAUSTED";
        case absl::StatusCode::kFailedPrecondition:
            return "FAILED_PRECONDITION";
        case absl::StatusCode::kAborted:
            return "ABORTED";
        case absl::StatusCode::kOutOfRange:
            return "OUT_OF_RANGE";
        case absl::StatusCode::kUnimplemented:
            return "UNIMPLEMENTED";
        case absl::StatusCode::kInternal:
            return "INTERNAL";
        case absl::StatusCode::kUnavailable:
            return "UNAVAILABLE";
        case absl::StatusCode::kDataLoss:
            return "DATA_LOSS";
        case absl::StatusCode::kUnauthenticated:
            return "UNAUTHENTICATED";
        default:
            return "UNKNOWN";
    }
}

absl::Status Annotate(const absl::Status& status, absl::string_view context) {
    if (status.ok()) return status;
    return absl::Status(status.code(), absl::StrCat(context, ": ", status.message()));
}

std::string JsonQuote(std::string_view text) {
    std::string out = "\"";
    for (const char c : text) {
        switch (c) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\r':
                out += "\\r";
                break;
            case '\t':
                out += "\\t";
                break;
            default:
                // Control bytes and bytes above ASCII (which may not be valid UTF-8) are escaped,
                // so the output is always valid JSON.
                if (const auto byte = static_cast<unsigned char>(c); byte < 0x20 || byte > 0x7e) {
                    char buffer[8];
                    std::snprintf(buffer, sizeof(buffer), "\\u%04x", static_cast<unsigned>(byte));
                    out += buffer;
                } else {
                    out += c;
                }
        }
    }
    return out + "\"";
}

std::string ErrorJson(const absl::Status& status) {
    return absl::StrCat("{\"code\":", static_cast<int>(status.code()),
                        ",\"message\":", JsonQuote(std::string(status.message())),
                        ",\"details\":[]}");
}

}  // namespace soilvol::server
