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

using WatchStop = absl::StatusOr<std::function<void()>>;
using WatchEndedFn = std::function<void(const absl::Status&)>;

template <typename Handler>
struct WatchTraits;
template <typename Req, typename Msg>
struct WatchTraits<WatchStop (SoilVolumeHandlers::*)(const Req&, std::function<bool(const Msg*)>,
                                                     WatchEndedFn)> {
    using Request = Req;
    using Message = Msg;
};

/// A server-streaming RPC over its handler (a template argument, as MakeRpc's).
template <auto watch>
StreamRpc MakeStream(SoilVolumeHandlers& handlers, const char* id_field, const char* resume_field,
                     const char* event) {
    using Request = typename WatchTraits<decltype(watch)>::Request;
    using Message = typename WatchTraits<decltype(watch)>::Message;
    StreamRpc rpc;
    rpc.new_request = [] { return std::make_unique<Request>(); };
    rpc.start = [&handlers](const google::protobuf::Message& request,
                            std::function<bool(const google::protobuf::Message*)> deliver,
                            WatchEndedFn ended) {
        return (handlers.*watch)(
            static_cast<const Request&>(request),
            [deliver = std::move(deliver)](const Message* message) { return deliver(message); },
            std::move(ended));
    };
    rpc.id_field = id_field;
    rpc.resume_field = resume_field;
    rpc.event = event;
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
    return {{"WatchEstimates", MakeStream<&SoilVolumeHandlers::WatchEstimates>(
                                   handlers, "estimate_id", "after_estimate_id", "estimate")},
            {"WatchAlerts", MakeStream<&SoilVolumeHandlers::WatchAlerts>(
                                handlers, "alert_id", "after_alert_id", "alert")},
            {"WatchLoads", MakeStream<&SoilVolumeHandlers::WatchLoads>(handlers, "event_id",
                                                                       "after_event_id", "load")}};
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
