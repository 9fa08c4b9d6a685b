#include <iostream>
#include <memory>
#include <string>
#include <vector>

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
    std::string mesh;          ///< the container's mesh file (STL, OBJ, PLY)
    std::string mesh_corners;  ///< its opening corners in its own frame
    std::string container_pose;
    double range_noise_m = 0.0;
    double max_range_m = 0.0;
    bool overwrite = false;
    ContainerSettings settings;
};

bool HasScan(const ScanOptions& scan) { return !scan.cloud.empty() || !scan.left.empty(); }

void AddPoints(const std::vector<std::vector<double>>& points,
               google::protobuf::RepeatedPtrField<v1::Point3>* out) {
    for (const auto& c : points) {
        v1::Point3* point = out->Add();
        point->set_x(c[0]);
        point->set_y(c[1]);
        point->set_z(c[2]);
    }
}

/// --mesh with its corners; alone (no scan) with the sensor's pose of it and range noise.
absl::StatusOr<v1::MeshScan> BuildMesh(const RegisterOptions& options) {
    v1::MeshScan mesh;
    const bool alone = !HasScan(options.scan);
    if (alone && (options.container_pose.empty() || options.range_noise_m <= 0.0)) {
        return absl::InvalidArgumentError(
            "--mesh without a scan needs --container-pose and --range-noise");
    }
    if (!alone && (!options.container_pose.empty() || options.range_noise_m > 0.0)) {
        return absl::InvalidArgumentError(
            "--container-pose and --range-noise are for a mesh without a scan (the scan places "
            "the container)");
    }
    auto corners = ParseTuples(options.mesh_corners, 3, 4, "--mesh-corners");
    if (!corners.ok()) return corners.status();
    AddPoints(*corners, mesh.mutable_corners());
    if (alone) {
        auto pose = ParsePose(options.container_pose, "--container-pose");
        if (!pose.ok()) return pose.status();
        v1::Point3* position = mesh.mutable_container_pose()->mutable_position_m();
        position->set_x(pose->position_m[0]);
        position->set_y(pose->position_m[1]);
        position->set_z(pose->position_m[2]);
        v1::Quaternion* q = mesh.mutable_container_pose()->mutable_orientation();
        q->set_w(pose->quaternion[0]);
        q->set_x(pose->quaternion[1]);
        q->set_y(pose->quaternion[2]);
        q->set_z(pose->quaternion[3]);
        mesh.set_range_noise_m(options.range_noise_m);
    }
    absl::StatusOr<std::string> data = ReadFile(options.mesh);
    if (!data.ok()) return data.status();
    mesh.set_data(*std::move(data));
    return mesh;
}

absl::Status AddOpening(const RegisterOptions& options, v1::Opening* opening) {
    if (options.corners.empty() == options.pixel_corners.empty()) {
        return absl::InvalidArgumentError(
            "a scan needs its opening: --corners (3D) or --pixel-corners (stereo), one of them");
    }
    if (!options.corners.empty()) {
        auto corners = ParseTuples(options.corners, 3, 4, "--corners");
        if (!corners.ok()) return corners.status();
        AddPoints(*corners, opening->mutable_corners());
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
    if (!options.mesh.empty()) {
        absl::StatusOr<v1::MeshScan> mesh = BuildMesh(options);
        if (!mesh.ok()) return ReportUsageError(mesh.status());
        *request.mutable_mesh() = *std::move(mesh);
    }
    if (HasScan(options.scan) || options.mesh.empty()) {
        absl::StatusOr<v1::Scan> scan = BuildScan(options.scan);
        if (!scan.ok()) return ReportUsageError(scan.status());
        *request.mutable_scan() = *std::move(scan);
        if (absl::Status status = AddOpening(options, request.mutable_opening()); !status.ok()) {
            return ReportUsageError(status);
        }
    } else if (!options.corners.empty() || !options.pixel_corners.empty()) {
        return ReportUsageError(absl::InvalidArgumentError(
            "--corners and --pixel-corners go with a scan; a mesh alone takes --mesh-corners"));
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
        "register",
        "register a container from a scan of it empty and its 4 opening corners, from its mesh, "
        "or from both");
    command->add_option("--id", options->id, "container id (the server picks one if omitted)");
    AddScanOptions(command, &options->scan, "empty container");
    auto* corners = command->add_option("--corners", options->corners,
                                        "opening corners in the scan frame [m]: "
                                        "\"x,y,z;x,y,z;x,y,z;x,y,z\", in order around it");
    auto* pixels = command->add_option("--pixel-corners", options->pixel_corners,
                                       "opening corners on the left image [px]: "
                                       "\"u,v;u,v;u,v;u,v\" (stereo only)");
    corners->excludes(pixels);
    auto* mesh = command->add_option("--mesh", options->mesh,
                                     "the container's mesh (STL, OBJ or PLY with faces) [m]: with "
                                     "a scan its exact inside, alone the whole model");
    auto* mesh_corners = command->add_option(
        "--mesh-corners", options->mesh_corners,
        "the opening's corners in the mesh's frame [m]: \"x,y,z;x,y,z;x,y,z;x,y,z\", in the "
        "order of --corners");
    auto* pose = command->add_option(
        "--container-pose", options->container_pose,
        "mesh alone: the mesh frame in the sensor's frame, \"x,y,z;qw,qx,qy,qz\" (position [m]; "
        "unit quaternion, w first) or \"x,y,z\"");
    auto* noise = command
                      ->add_option("--range-noise", options->range_noise_m,
                                   "mesh alone: the sensor's range noise, 1 sigma [m] "
                                   "(0.001-0.5)")
                      ->check(CLI::PositiveNumber);
    mesh->needs(mesh_corners);
    for (auto* option : {mesh_corners, pose, noise}) option->needs(mesh);
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
