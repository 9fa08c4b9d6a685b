#pragma once

#include <map>
#include <string>

#include "server/dispatch/dispatcher.hpp"
#include "server/handlers/rpc_list.hpp"
#include "server/handlers/rpc_table.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "soilvol/v1/soilvol.grpc.pb.h"

namespace soilvol::server {

/// soilvol.v1.SoilVolume over gRPC's callback API: each call goes to the Dispatcher (the
/// bounded worker pool), never blocks a gRPC thread, and finishes with the mapped status.
class SoilVolumeService final : public v1::SoilVolume::CallbackService {
  public:
    /// `rpcs` (MakeRpcTable, checked by CheckRpcTable) serves every unary RPC, as it does for
    /// REST; `handlers` the stream.
    SoilVolumeService(const std::map<std::string, Rpc>& rpcs, SoilVolumeHandlers& handlers,
                      Dispatcher& dispatcher);

#define SOILVOL_DECLARE_UNARY(Name, Request, Response)                   \
    grpc::ServerUnaryReactor* Name(grpc::CallbackServerContext* context, \
                                   const v1::Request* request, v1::Response* response) override;
    SOILVOL_UNARY_RPCS(SOILVOL_DECLARE_UNARY)
#undef SOILVOL_DECLARE_UNARY
    grpc::ServerBidiReactor<v1::EstimateVolumeRequest, v1::StreamEstimatesResponse>*
    StreamEstimates(grpc::CallbackServerContext* context) override;
    grpc::ServerWriteReactor<v1::Estimate>* WatchEstimates(
        grpc::CallbackServerContext* context, const v1::WatchEstimatesRequest* request) override;
    grpc::ServerWriteReactor<v1::Alert>* WatchAlerts(
        grpc::CallbackServerContext* context, const v1::WatchAlertsRequest* request) override;
    grpc::ServerWriteReactor<v1::LoadEvent>* WatchLoads(
        grpc::CallbackServerContext* context, const v1::WatchLoadsRequest* request) override;

  private:
    grpc::ServerUnaryReactor* Unary(grpc::CallbackServerContext* context, const char* method,
                                    const google::protobuf::Message* request,
                                    google::protobuf::Message* response);

    const std::map<std::string, Rpc>& rpcs_;
    SoilVolumeHandlers& handlers_;
    Dispatcher& dispatcher_;
};

/// The dispatcher's view of a gRPC call: method, peer, deadline, cancellation.
CallContext GrpcCallContext(grpc::CallbackServerContext* context, const char* method);

/// absl and gRPC share status codes.
grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace soilvol::server
