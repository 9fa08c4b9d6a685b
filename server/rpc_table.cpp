#include "server/rpc_table.hpp"

namespace soilvol::server {
namespace {

template <typename Request, typename Response>
Rpc MakeRpc(SoilVolumeHandlers& handlers,
            absl::Status (SoilVolumeHandlers::*handler)(const Request&, Response*, CallRecord&)) {
    Rpc rpc;
    rpc.new_request = [] { return std::make_unique<Request>(); };
    rpc.new_response = [] { return std::make_unique<Response>(); };
    rpc.call = [&handlers, handler](const google::protobuf::Message& request,
                                    google::protobuf::Message* response, CallRecord& record) {
        return (handlers.*handler)(static_cast<const Request&>(request),
                                   static_cast<Response*>(response), record);
    };
    return rpc;
}

}  // namespace

std::map<std::string, Rpc> MakeRpcTable(SoilVolumeHandlers& h) {
    using H = SoilVolumeHandlers;
    return {
        {"Calibrate", MakeRpc(h, &H::Calibrate)},
        {"GetCalibration", MakeRpc(h, &H::GetCalibration)},
        {"ListCalibrations", MakeRpc(h, &H::ListCalibrations)},
        {"DeleteCalibration", MakeRpc(h, &H::DeleteCalibration)},
        {"RegisterContainer", MakeRpc(h, &H::RegisterContainer)},
        {"GetContainer", MakeRpc(h, &H::GetContainer)},
        {"ListContainers", MakeRpc(h, &H::ListContainers)},
        {"DeleteContainer", MakeRpc(h, &H::DeleteContainer)},
        {"EstimateVolume", MakeRpc(h, &H::EstimateVolume)},
    };
}

}  // namespace soilvol::server
