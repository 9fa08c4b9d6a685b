#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/http_probe.hpp"
#include "client/response_printer.hpp"

namespace soilvol::client {
namespace {

// /readyz of the probe listener: no TLS, no token, as a container runtime's check needs.
int RunProbe(const std::string& host_port, const GlobalOptions& global) {
    std::string body;
    std::string error;
    const int status = HttpGet(host_port, "/readyz", global.timeout_s, &body, &error);
    if (status < 0) {
        std::cerr << "error: UNAVAILABLE: " << host_port << ": " << error << "\n";
        return kExitRpcError;
    }
    std::cout << (status == 200 ? "SERVING" : "NOT_SERVING") << "\n";
    return status == 200 ? kExitOk : kExitRpcError;
}

int RunHealth(const std::string& service, const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
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
    auto probe = std::make_shared<std::string>();
    auto* command = app.add_subcommand("health", "grpc.health.v1 check; exit 0 only when SERVING");
    command->add_option("--service", *service, "service name (default \"\": the whole server)");
    command->add_option("--probe", *probe,
                        "host:port of the server's plain-HTTP probe listener: GET /readyz there "
                        "instead (no TLS, no token)");
    command->callback([service, probe, &global, exit_code] {
        *exit_code = probe->empty() ? RunHealth(*service, global) : RunProbe(*probe, global);
    });
}

}  // namespace soilvol::client
