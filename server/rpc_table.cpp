#include "server/rpc_table.hpp"

#include "absl/strings/str_cat.h"

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
        {"GetServerInfo", MakeRpc(h, &H::GetServerInfo)},
    };
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
