#include "server/base/status_map.hpp"

#include <cctype>
#include <cstdio>

#include "absl/strings/cord.h"
#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "google/rpc/error_details.pb.h"
#include "google/rpc/status.pb.h"

namespace soilvol::server {
namespace {

constexpr absl::string_view kReasonPayload = "type.soilvol.dev/reason";
constexpr const char* kDomain = "soilvol";

bool IsFieldName(std::string_view name) {
    if (name.empty() || !std::islower(static_cast<unsigned char>(name.front()))) return false;
    for (const char c : name) {
        if (!std::islower(static_cast<unsigned char>(c)) &&
            !std::isdigit(static_cast<unsigned char>(c)) && c != '_') {
            return false;
        }
    }
    return true;
}

/// "name" or "name[12]".
bool IsFieldStep(std::string_view step) {
    const std::size_t open = step.find('[');
    if (open == std::string_view::npos) return IsFieldName(step);
    if (step.back() != ']' || open + 2 >= step.size()) return false;
    for (std::size_t i = open + 1; i + 1 < step.size(); ++i) {
        if (!std::isdigit(static_cast<unsigned char>(step[i]))) return false;
    }
    return IsFieldName(step.substr(0, open));
}

enum class Escape { kJson, kC };

/// `c` when it is printable ASCII, else its byte escaped: \u00NN (JSON) or \xNN.
void AppendPrintable(char c, Escape escape, std::string* out) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte >= 0x20 && byte <= 0x7e) {
        *out += c;
        return;
    }
    char buffer[8];
    if (escape == Escape::kJson) {
        std::snprintf(buffer, sizeof(buffer), "\\u%04x", static_cast<unsigned>(byte));
    } else {
        std::snprintf(buffer, sizeof(buffer), "\\x%02x", static_cast<unsigned>(byte));
    }
    *out += buffer;
}

}  // namespace

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
                AppendPrintable(c, Escape::kJson, &out);
        }
    }
    return out + "\"";
}

absl::Status WithReason(absl::Status status, std::string_view reason) {
    status.SetPayload(kReasonPayload, absl::Cord(absl::string_view(reason.data(), reason.size())));
    return status;
}

std::string FieldOf(absl::string_view message) {
    const std::size_t end = message.find(": ");
    if (end == absl::string_view::npos) return "";
    const std::string_view path(message.data(), end);
    std::size_t start = 0;
    while (start <= path.size()) {
        std::size_t dot = path.find('.', start);
        if (dot == std::string_view::npos) dot = path.size();
        if (!IsFieldStep(path.substr(start, dot - start))) return "";
        start = dot + 1;
    }
    return std::string(path);
}

int RetryAfterSeconds(const absl::Status& status) {
    const absl::optional<absl::Cord> reason = status.GetPayload(kReasonPayload);
    if (reason && *reason == absl::string_view(kReasonTooLarge.data(), kReasonTooLarge.size())) {
        return 0;
    }
    return status.code() == absl::StatusCode::kResourceExhausted ||
                   status.code() == absl::StatusCode::kUnavailable
               ? 1
               : 0;
}

std::string SafeMessage(absl::string_view message) {
    std::string out;
    out.reserve(message.size());
    for (const char c : message) AppendPrintable(c, Escape::kC, &out);
    return out;
}

google::rpc::Status RpcStatusOf(const absl::Status& status) {
    google::rpc::Status out;
    out.set_code(static_cast<int>(status.code()));
    out.set_message(SafeMessage(status.message()));
    const std::string field = FieldOf(status.message());

    google::rpc::ErrorInfo info;
    const absl::optional<absl::Cord> reason = status.GetPayload(kReasonPayload);
    info.set_reason(reason ? std::string(*reason) : std::string(CodeName(status.code())));
    info.set_domain(kDomain);
    if (!field.empty()) (*info.mutable_metadata())["field"] = field;
    out.add_details()->PackFrom(info);

    if (!field.empty() && (status.code() == absl::StatusCode::kInvalidArgument ||
                           status.code() == absl::StatusCode::kOutOfRange)) {
        google::rpc::BadRequest bad;
        google::rpc::BadRequest::FieldViolation* violation = bad.add_field_violations();
        violation->set_field(field);
        violation->set_description(out.message().substr(field.size() + 2));
        out.add_details()->PackFrom(bad);
    }
    if (const int seconds = RetryAfterSeconds(status); seconds > 0) {
        google::rpc::RetryInfo retry;
        retry.mutable_retry_delay()->set_seconds(seconds);
        out.add_details()->PackFrom(retry);
    }
    return out;
}

std::string RpcStatusBytes(const absl::Status& status) {
    if (status.ok()) return "";
    return RpcStatusOf(status).SerializeAsString();
}

std::string ErrorJson(const absl::Status& status) {
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(RpcStatusOf(status), &json).ok()) {
        // Only an unresolvable detail type could get here; the code and message still go out.
        return absl::StrCat("{\"code\":", static_cast<int>(status.code()),
                            ",\"message\":", JsonQuote(SafeMessage(status.message())), "}");
    }
    return json;
}

}  // namespace soilvol::server
