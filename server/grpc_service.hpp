#pragma once

#include <map>
#include <string>

#include "server/dispatcher.hpp"
#include "server/rpc_table.hpp"
#include "server/soilvol_handlers.hpp"
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

    grpc::ServerUnaryReactor* Calibrate(grpc::CallbackServerContext* context,
                                        const v1::CalibrateRequest* request,
                                        v1::Calibration* response) override;
    grpc::ServerUnaryReactor* GetCalibration(grpc::CallbackServerContext* context,
                                             const v1::GetCalibrationRequest* request,
                                             v1::Calibration* response) override;
    grpc::ServerUnaryReactor* ListCalibrations(grpc::CallbackServerContext* context,
                                               const v1::ListCalibrationsRequest* request,
                                               v1::ListCalibrationsResponse* response) override;
    grpc::ServerUnaryReactor* DeleteCalibration(grpc::CallbackServerContext* context,
                                                const v1::DeleteCalibrationRequest* request,
                                                v1::DeleteCalibrationResponse* response) override;
    grpc::ServerUnaryReactor* RegisterContainer(grpc::CallbackServerContext* context,
                                                const v1::RegisterContainerRequest* request,
                                                v1::Container* response) override;
    grpc::ServerUnaryReactor* GetContainer(grpc::CallbackServerContext* context,
                                           const v1::GetContainerRequest* request,
                                           v1::Container* response) override;
    grpc::ServerUnaryReactor* ListContainers(grpc::CallbackServerContext* context,
                                             const v1::ListContainersRequest* request,
                                             v1::ListContainersResponse* response) override;
    grpc::ServerUnaryReactor* UpdateContainer(grpc::CallbackServerContext* context,
                                              const v1::UpdateContainerRequest* request,
                                              v1::Container* response) override;
    grpc::ServerUnaryReactor* GetEstimate(grpc::CallbackServerContext* context,
                                          const v1::GetEstimateRequest* request,
                                          v1::Estimate* response) override;
    grpc::ServerUnaryReactor* ListEstimates(grpc::CallbackServerContext* context,
                                            const v1::ListEstimatesRequest* request,
                                            v1::ListEstimatesResponse* response) override;
    grpc::ServerUnaryReactor* DeleteContainer(grpc::CallbackServerContext* context,
                                              const v1::DeleteContainerRequest* request,
                                              v1::DeleteContainerResponse* response) override;
    grpc::ServerUnaryReactor* EstimateVolume(grpc::CallbackServerContext* context,
                                             const v1::EstimateVolumeRequest* request,
                                             v1::EstimateVolumeResponse* response) override;
    grpc::ServerUnaryReactor* GetServerInfo(grpc::CallbackServerContext* context,
                                            const v1::GetServerInfoRequest* request,
                                            v1::ServerInfo* response) override;
    grpc::ServerBidiReactor<v1::EstimateVolumeRequest, v1::StreamEstimatesResponse>*
    StreamEstimates(grpc::CallbackServerContext* context) override;
    grpc::ServerWriteReactor<v1::Estimate>* WatchEstimates(
        grpc::CallbackServerContext* context, const v1::WatchEstimatesRequest* request) override;

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
