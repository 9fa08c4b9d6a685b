#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/container_settings.hpp"
#include "client/input_files.hpp"
#include "client/response_printer.hpp"
#include "client/scan_options.hpp"

namespace soilvol::client {
namespace {

struct RegisterOptions {
    std::string id;
    ScanOptions scan;
    std::string corners;
    std::string pixel_corners;
    double max_range_m = 0.0;
    bool overwrite = false;
    ContainerSettings settings;
};

absl::Status AddOpening(const RegisterOptions& options, v1::Opening* opening) {
    if (!options.corners.empty()) {
        auto corners = ParseTuples(options.corners, 3, 4, "--corners");
        if (!corners.ok()) return corners.status();
        for (const auto& c : *corners) {
            v1::Point3* point = opening->add_corners();
            point->set_x(c[0]);
            point->set_y(c[1]);
            point->set_z(c[2]);
        }
        return absl::OkStatus();
    }
    auto pixels = ParseTuples(options.pixel_corners, 2, 4, "--pixel-corners");
    if (!pixels.ok()) return pixels.status();
    for (const auto& p : *pixels) {
        v1::PixelPoint* pixel = opening->add_pixel_corners();
        pixel->set_u(p[0]);
        pixel->set_v(p[1]);
    }
    return absl::OkStatus();
}

int RunRegister(const RegisterOptions& options, bool has_max_range, const GlobalOptions& global) {
    v1::RegisterContainerRequest request;
    request.set_container_id(options.id);
    request.set_overwrite(options.overwrite);
    if (has_max_range) request.set_max_range_m(options.max_range_m);
    absl::StatusOr<v1::Scan> scan = BuildScan(options.scan);
    if (!scan.ok()) return ReportUsageError(scan.status());
    *request.mutable_scan() = *std::move(scan);
    if (absl::Status status = AddOpening(options, request.mutable_opening()); !status.ok()) {
        return ReportUsageError(status);
    }
    v1::Container settings;
    if (absl::Status status = ApplySettings(options.settings, &settings, nullptr); !status.ok()) {
        return ReportUsageError(status);
    }
    request.set_display_name(settings.display_name());
    *request.mutable_labels() = settings.labels();
    if (settings.has_material()) *request.mutable_material() = settings.material();
    if (settings.has_load_targets()) *request.mutable_load_targets() = settings.load_targets();
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::Container container;
    const auto context = connection.NewContext();
    const grpc::Status status =
        connection.Soil().RegisterContainer(context.get(), request, &container);
    if (!status.ok()) return ReportRpcError(status);
    PrintContainer(container, global.json, std::cout);
    return kExitOk;
}

}  // namespace

void AddRegisterCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto options = std::make_shared<RegisterOptions>();
    auto* command = app.add_subcommand(
        "register", "register a container from a scan of it empty and its 4 opening corners");
    command->add_option("--id", options->id, "container id (the server picks one if omitted)");
    AddScanOptions(command, &options->scan, "empty container");
    auto* corners = command->add_option("--corners", options->corners,
                                        "opening corners in the scan frame [m]: "
                                        "\"x,y,z;x,y,z;x,y,z;x,y,z\", in order around it");
    auto* pixels = command->add_option("--pixel-corners", options->pixel_corners,
                                       "opening corners on the left image [px]: "
                                       "\"u,v;u,v;u,v;u,v\" (stereo only)");
    auto* corner_group = command->add_option_group("opening", "the opening's four corners");
    corner_group->add_option(corners);
    corner_group->add_option(pixels);
    corner_group->require_option(1);
    auto* range = command
                      ->add_option("--max-range-m", options->max_range_m,
                                   "points farther from the sensor are background [m]")
                      ->check(CLI::PositiveNumber);
    command->add_flag("--overwrite", options->overwrite, "replace a container with this id");
    AddSettingsOptions(command, &options->settings);
    command->callback([options, range, &global, exit_code] {
        *exit_code = RunRegister(*options, range->count() > 0, global);
    });
}

}  // namespace soilvol::client
