#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/response_printer.hpp"

namespace soilvol::client {
namespace {

int RunHealth(const std::string& service, const GlobalOptions& global) {
    Connection connection(global);
    grpc::health::v1::HealthCheckRequest request;
    request.set_service(service);
    grpc::health::v1::HealthCheckResponse response;
    const auto context = connection.NewContext();
    const grpc::Status status = connection.Health().Check(context.get(), request, &response);
    if (!status.ok()) return ReportRpcError(status);
    if (global.json) {
        PrintJson(response, std::cout);
    } else {
        std::cout << grpc::health::v1::HealthCheckResponse_ServingStatus_Name(response.status())
                  << "\n";
    }
    return response.status() == grpc::health::v1::HealthCheckResponse::SERVING ? kExitOk
                                                                               : kExitRpcError;
}

}  // namespace

void AddHealthCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto service = std::make_shared<std::string>();
    auto* command = app.add_subcommand("health", "grpc.health.v1 check; exit 0 only when SERVING");
    command->add_option("--service", *service, "service name (default \"\": the whole server)");
    command->callback([service, &global, exit_code] { *exit_code = RunHealth(*service, global); });
}

}  // namespace soilvol::client
