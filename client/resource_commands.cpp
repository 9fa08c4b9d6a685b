#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/container_settings.hpp"
#include "client/input_files.hpp"
#include "client/response_printer.hpp"

namespace soilvol::client {
namespace {

enum class Action { kList, kGet, kDelete };

/// Every page of a List RPC (AIP-158), merged into `all`; each page is its own call.
template <typename Request, typename Response, typename Call>
grpc::Status ListAll(Connection& connection, Call call, Response* all) {
    Request request;
    request.set_page_size(1000);
    do {
        Response page;
        const auto context = connection.NewContext();
        if (grpc::Status status = call(context.get(), request, &page); !status.ok()) return status;
        request.set_page_token(page.next_page_token());
        page.clear_next_page_token();
        all->MergeFrom(page);
    } while (!request.page_token().empty());
    return grpc::Status::OK;
}

/// Flags of `<noun> delete`.
struct DeleteFlags {
    bool purge_records = false;  ///< containers: their estimate records too
};

int RunContainers(Action action, const std::string& id, const DeleteFlags& flags,
                  const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    const auto context = connection.NewContext();
    grpc::Status status;
    if (action == Action::kList) {
        v1::ListContainersResponse list;
        status = ListAll<v1::ListContainersRequest>(
            connection,
            [&connection](grpc::ClientContext* c, const v1::ListContainersRequest& request,
                          v1::ListContainersResponse* page) {
                return connection.Soil().ListContainers(c, request, page);
            },
            &list);
        if (status.ok()) PrintContainerList(list, global.json, std::cout);
    } else if (action == Action::kGet) {
        v1::GetContainerRequest request;
        request.set_container_id(id);
        v1::Container container;
        status = connection.Soil().GetContainer(context.get(), request, &container);
        if (status.ok()) PrintContainer(container, global.json, std::cout);
    } else {
        v1::DeleteContainerRequest request;
        request.set_container_id(id);
        request.set_purge_records(flags.purge_records);
        v1::DeleteContainerResponse deleted;
        status = connection.Soil().DeleteContainer(context.get(), request, &deleted);
        if (status.ok() && global.json) PrintJson(deleted, std::cout);
        if (status.ok() && !global.json) std::cout << "deleted container " << id << "\n";
    }
    return status.ok() ? kExitOk : ReportRpcError(status);
}

int RunCalibrations(Action action, const std::string& id, const DeleteFlags&,
                    const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    const auto context = connection.NewContext();
    grpc::Status status;
    if (action == Action::kList) {
        v1::ListCalibrationsResponse list;
        status = ListAll<v1::ListCalibrationsRequest>(
            connection,
            [&connection](grpc::ClientContext* c, const v1::ListCalibrationsRequest& request,
                          v1::ListCalibrationsResponse* page) {
                return connection.Soil().ListCalibrations(c, request, page);
            },
            &list);
        if (status.ok()) PrintCalibrationList(list, global.json, std::cout);
    } else if (action == Action::kGet) {
        v1::GetCalibrationRequest request;
        request.set_calibration_id(id);
        v1::Calibration calibration;
        status = connection.Soil().GetCalibration(context.get(), request, &calibration);
        if (status.ok()) PrintCalibration(calibration, global.json, std::cout);
    } else {
        v1::DeleteCalibrationRequest request;
        request.set_calibration_id(id);
        v1::DeleteCalibrationResponse deleted;
        status = connection.Soil().DeleteCalibration(context.get(), request, &deleted);
        if (status.ok() && global.json) PrintJson(deleted, std::cout);
        if (status.ok() && !global.json) std::cout << "deleted calibration " << id << "\n";
    }
    return status.ok() ? kExitOk : ReportRpcError(status);
}

int RunUpdate(const std::string& id, const std::string& etag, const ContainerSettings& settings,
              const GlobalOptions& global) {
    v1::UpdateContainerRequest request;
    request.mutable_container()->set_container_id(id);
    request.mutable_container()->set_etag(etag);
    if (absl::Status status =
            ApplySettings(settings, request.mutable_container(), request.mutable_update_mask());
        !status.ok()) {
        return ReportUsageError(status);
    }
    if (request.update_mask().paths_size() == 0) {
        return ReportUsageError(absl::InvalidArgumentError("give at least one setting to change"));
    }
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    const auto context = connection.NewContext();
    v1::Container container;
    const grpc::Status status =
        connection.Soil().UpdateContainer(context.get(), request, &container);
    if (!status.ok()) return ReportRpcError(status);
    PrintContainer(container, global.json, std::cout);
    return kExitOk;
}

void AddUpdateCommand(CLI::App& containers, const GlobalOptions& global, int* exit_code) {
    struct Options {
        std::string id, etag;
        ContainerSettings settings;
    };
    auto options = std::make_shared<Options>();
    auto* command = containers.add_subcommand(
        "update", "change a container's name, labels, material or load targets (no rescan)");
    command->add_option("id", options->id, "container id")->required();
    command->add_option("--etag", options->etag, "update only the container at this etag");
    AddSettingsOptions(command, &options->settings);
    command->callback([options, &global, exit_code] {
        *exit_code = RunUpdate(options->id, options->etag, options->settings, global);
    });
}

using Runner = int (*)(Action, const std::string&, const DeleteFlags&, const GlobalOptions&);

// `<noun> list | get ID | delete ID`.
void AddResource(CLI::App& app, const std::string& noun, const std::string& singular, Runner run,
                 bool has_records, const GlobalOptions& global, int* exit_code) {
    auto* group = app.add_subcommand(noun, "list, show or delete " + noun);
    group->require_subcommand(1);
    group->add_subcommand("list", "list every " + singular)->callback([run, &global, exit_code] {
        *exit_code = run(Action::kList, "", DeleteFlags{}, global);
    });
    for (const auto& [name, action] :
         {std::pair{"get", Action::kGet}, std::pair{"delete", Action::kDelete}}) {
        auto id = std::make_shared<std::string>();
        auto flags = std::make_shared<DeleteFlags>();
        auto* command = group->add_subcommand(name, std::string(name) + " one " + singular);
        command->add_option("id", *id, singular + " id")->required();
        if (action == Action::kDelete && has_records) {
            command->add_flag("--purge-records", flags->purge_records,
                              "also delete its estimate records (kept by default)");
        }
        command->callback([run, action = action, id, flags, &global, exit_code] {
            *exit_code = run(action, *id, *flags, global);
        });
    }
}

}  // namespace

void AddResourceCommands(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    AddResource(app, "containers", "container", RunContainers, true, global, exit_code);
    AddUpdateCommand(*app.get_subcommand("containers"), global, exit_code);
    AddResource(app, "calibrations", "calibration", RunCalibrations, false, global, exit_code);
}

}  // namespace soilvol::client
