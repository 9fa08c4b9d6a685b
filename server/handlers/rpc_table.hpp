#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "google/protobuf/descriptor.h"
#include "google/protobuf/message.h"
#include "server/handlers/call_record.hpp"
#include "server/handlers/soilvol_handlers.hpp"

namespace soilvol::server {

/// One RPC with its messages erased: what both transports call.
struct Rpc {
    std::function<std::unique_ptr<google::protobuf::Message>()> new_request;
    std::function<std::unique_ptr<google::protobuf::Message>()> new_response;
    std::function<absl::Status(const google::protobuf::Message&, google::protobuf::Message*,
                               CallRecord&)>
        call;
};

/// One server-streaming RPC with its messages erased: gRPC writes what it delivers, REST sends
/// it as Server-Sent Events.
struct StreamRpc {
    std::function<std::unique_ptr<google::protobuf::Message>()> new_request;
    /// Starts the stream: `deliver` gets each message (null: a heartbeat; false ends the
    /// stream), `ended` why the server ended it. Returns the function that stops it.
    std::function<absl::StatusOr<std::function<void()>>(
        const google::protobuf::Message& request,
        std::function<bool(const google::protobuf::Message*)> deliver,
        std::function<void(const absl::Status&)> ended)>
        start;
    /// The field of each message that names it for a resume (SSE event ids), and the request
    /// field a resume sets (from Last-Event-ID).
    std::string id_field, resume_field;
    /// The SSE event name of each message ("estimate").
    std::string event;
};

/// Every server-streaming RPC by name ("WatchEstimates").
std::map<std::string, StreamRpc> MakeStreamTable(SoilVolumeHandlers& handlers);

/// Every unary RPC of soilvol.v1.SoilVolume by name ("EstimateVolume"), calling `handlers`.
std::map<std::string, Rpc> MakeRpcTable(SoilVolumeHandlers& handlers);

/// Internal naming the first RPC that `service` declares unary (every one is annotated for
/// REST) but `table` has no entry for, or whose messages differ from the descriptor's: the
/// server refuses to start rather than answer such a route with a 500.
absl::Status CheckRpcTable(const std::map<std::string, Rpc>& table,
                           const google::protobuf::ServiceDescriptor& service);

}  // namespace soilvol::server
