#include "server/handlers/rpc_table.hpp"

#include "absl/strings/str_cat.h"
#include "server/handlers/rpc_list.hpp"

namespace soilvol::server {
namespace {

template <typename Handler>
struct HandlerTraits;
template <typename Req, typename Resp>
struct HandlerTraits<absl::Status (SoilVolumeHandlers::*)(const Req&, Resp*, CallRecord&)> {
    using Request = Req;
    using Response = Resp;
};

/// The handler is a template argument, not a value the closure captures: GCC 12 with
/// -fsanitize=address,undefined miscompiles a call through a captured member-function pointer
/// in a std::function (it warns "may be used uninitialized" there, then the call jumps through
/// a wild this-adjustment).
template <auto handler>
Rpc MakeRpc(SoilVolumeHandlers& handlers) {
    using Request = typename HandlerTraits<decltype(handler)>::Request;
    using Response = typename HandlerTraits<decltype(handler)>::Response;
    Rpc rpc;
    rpc.new_request = [] { return std::make_unique<Request>(); };
    rpc.new_response = [] { return std::make_unique<Response>(); };
    rpc.call = [&handlers](const google::protobuf::Message& request,
                           google::protobuf::Message* response, CallRecord& record) {
        return (handlers.*handler)(static_cast<const Request&>(request),
                                   static_cast<Response*>(response), record);
    };
    return rpc;
}

}  // namespace

std::map<std::string, Rpc> MakeRpcTable(SoilVolumeHandlers& h) {
    std::map<std::string, Rpc> table;
#define SOILVOL_TABLE_ENTRY(Name, Request, Response) \
    table.emplace(#Name, MakeRpc<&SoilVolumeHandlers::Name>(h));
    SOILVOL_UNARY_RPCS(SOILVOL_TABLE_ENTRY)
#undef SOILVOL_TABLE_ENTRY
    return table;
}

std::map<std::string, StreamRpc> MakeStreamTable(SoilVolumeHandlers& handlers) {
    StreamRpc estimates;
    estimates.new_request = [] { return std::make_unique<v1::WatchEstimatesRequest>(); };
    estimates.start = [&handlers](const google::protobuf::Message& request,
                                  std::function<bool(const google::protobuf::Message*)> deliver,
                                  std::function<void(const absl::Status&)> ended) {
        return handlers.WatchEstimates(
            static_cast<const v1::WatchEstimatesRequest&>(request),
            [deliver = std::move(deliver)](const v1::Estimate* estimate) {
                return deliver(estimate);
            },
            std::move(ended));
    };
    estimates.id_field = "estimate_id";
    estimates.resume_field = "after_estimate_id";
    estimates.event = "estimate";
    StreamRpc alerts;
    alerts.new_request = [] { return std::make_unique<v1::WatchAlertsRequest>(); };
    alerts.start = [&handlers](const google::protobuf::Message& request,
                               std::function<bool(const google::protobuf::Message*)> deliver,
                               std::function<void(const absl::Status&)> ended) {
        return handlers.WatchAlerts(
            static_cast<const v1::WatchAlertsRequest&>(request),
            [deliver = std::move(deliver)](const v1::Alert* alert) { return deliver(alert); },
            std::move(ended));
    };
    alerts.id_field = "alert_id";
    alerts.resume_field = "after_alert_id";
    alerts.event = "alert";
    return {{"WatchEstimates", std::move(estimates)}, {"WatchAlerts", std::move(alerts)}};
}

absl::Status CheckRpcTable(const std::map<std::string, Rpc>& table,
                           const google::protobuf::ServiceDescriptor& service) {
    for (int i = 0; i < service.method_count(); ++i) {
        const google::protobuf::MethodDescriptor& method = *service.method(i);
        if (method.client_streaming() || method.server_streaming()) continue;
        const auto found = table.find(method.name());
        if (found == table.end()) {
            return absl::InternalError(
                absl::StrCat("RPC ", method.full_name(), " has no handler in the RPC table"));
        }
        if (found->second.new_request()->GetDescriptor() != method.input_type() ||
            found->second.new_response()->GetDescriptor() != method.output_type()) {
            return absl::InternalError(absl::StrCat("RPC ", method.full_name(),
                                                    ": the table's messages differ from the "
                                                    "service's"));
        }
    }
    return absl::OkStatus();
}

}  // namespace soilvol::server
