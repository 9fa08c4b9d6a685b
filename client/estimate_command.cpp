#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/input_files.hpp"
#include "client/response_printer.hpp"
#include "client/scan_options.hpp"

namespace soilvol::client {
namespace {

struct EstimateOptions {
    std::string id;
    ScanOptions scan;
    double cell_m = 0.0;
    std::string method;  ///< heightmap, paper, or empty for the server's default
    double density_kg_m3 = 0.0;
    std::string request_id;
    std::string load;
};

int RunEstimate(const EstimateOptions& options, bool has_cell, bool has_density,
                const GlobalOptions& global) {
    v1::EstimateVolumeRequest request;
    request.set_container_id(options.id);
    request.set_method(options.method == "paper"       ? v1::ESTIMATION_METHOD_PAPER
                       : options.method == "heightmap" ? v1::ESTIMATION_METHOD_HEIGHTMAP
                                                       : v1::ESTIMATION_METHOD_UNSPECIFIED);
    request.set_request_id(options.request_id);
    request.set_load_id(options.load);
    if (has_cell) request.set_grid_cell_m(options.cell_m);
    if (has_density) request.set_material_density_kg_m3(options.density_kg_m3);
    absl::StatusOr<v1::Scan> scan = BuildScan(options.scan);
    if (!scan.ok()) return ReportUsageError(scan.status());
    *request.mutable_scan() = *std::move(scan);
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::EstimateVolumeResponse estimate;
    const auto context = connection.NewContext();
    const grpc::Status status = connection.Soil().EstimateVolume(context.get(), request, &estimate);
    if (!status.ok()) return ReportRpcError(status);
    PrintEstimate(estimate, global.json, std::cout);
    return kExitOk;
}

}  // namespace

void AddEstimateCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto options = std::make_shared<EstimateOptions>();
    auto* command =
        app.add_subcommand("estimate", "volume of the soil in a scan of a registered container");
    command->add_option("--id", options->id, "container id")->required();
    AddScanOptions(command, &options->scan, "scan");
    auto* cell = command
                     ->add_option("--cell-m", options->cell_m,
                                  "grid cell side [m] (default: automatic, paper 0.10)")
                     ->check(CLI::PositiveNumber);
    command->add_option("--method", options->method, "heightmap (server default) or paper")
        ->check(CLI::IsMember({"heightmap", "paper"}));
    auto* density = command
                        ->add_option("--density-kg-m3", options->density_kg_m3,
                                     "material density [kg/m^3]: report the mass")
                        ->check(CLI::PositiveNumber);
    command->add_option("--request-id", options->request_id, "echoed in the response");
    command->add_option("--load", options->load,
                        "the truck load this scan is a pass of (or the body scan of)");
    command->callback([options, cell, density, &global, exit_code] {
        *exit_code = RunEstimate(*options, cell->count() > 0, density->count() > 0, global);
    });
}

}  // namespace soilvol::client
