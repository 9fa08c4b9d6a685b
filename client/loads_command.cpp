#include <iostream>
#include <memory>
#include <string>

#include "client/commands.hpp"
#include "client/load_printer.hpp"
#include "client/response_printer.hpp"
#include "client/watch_loop.hpp"

namespace soilvol::client {
namespace {

struct CreateOptions {
    std::string id, haul_unit, body, display_name, request_id;
    double target_m3 = 0.0, target_kg = 0.0;
};

/// Runs one unary RPC against the server and prints its answer with `print`.
template <typename Request, typename Response, typename Call, typename Print>
int RunUnary(const GlobalOptions& global, const Request& request, Call call, Print print) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    const auto context = connection.NewContext();
    Response response;
    const grpc::Status status = call(connection.Soil(), context.get(), request, &response);
    if (!status.ok()) return ReportRpcError(status);
    print(response, global.json, std::cout);
    return kExitOk;
}

int RunCreate(const CreateOptions& options, const GlobalOptions& global) {
    v1::CreateLoadRequest request;
    request.set_load_id(options.id);
    request.set_request_id(options.request_id);
    v1::Load* load = request.mutable_load();
    load->set_haul_unit_id(options.haul_unit);
    load->set_body_container_id(options.body);
    load->set_display_name(options.display_name);
    if (options.target_m3 > 0.0) load->mutable_targets()->set_volume_m3(options.target_m3);
    if (options.target_kg > 0.0) load->mutable_targets()->set_payload_kg(options.target_kg);
    return RunUnary<v1::CreateLoadRequest, v1::Load>(
        global, request,
        [](auto& soil, auto* context, const auto& r, auto* out) {
            return soil.CreateLoad(context, r, out);
        },
        PrintLoad);
}

int RunGet(const std::string& id, const GlobalOptions& global) {
    v1::GetLoadRequest request;
    request.set_load_id(id);
    return RunUnary<v1::GetLoadRequest, v1::Load>(
        global, request,
        [](auto& soil, auto* context, const auto& r, auto* out) {
            return soil.GetLoad(context, r, out);
        },
        PrintLoad);
}

int RunClose(const std::string& id, const std::string& etag, const GlobalOptions& global) {
    v1::CloseLoadRequest request;
    request.set_load_id(id);
    request.set_etag(etag);
    return RunUnary<v1::CloseLoadRequest, v1::Load>(
        global, request,
        [](auto& soil, auto* context, const auto& r, auto* out) {
            return soil.CloseLoad(context, r, out);
        },
        PrintLoad);
}

struct ListOptions {
    std::string haul_unit, state;
    int limit = 100;
};

int RunList(const ListOptions& options, const GlobalOptions& global) {
    v1::ListLoadsRequest request;
    request.set_haul_unit_id(options.haul_unit);
    request.set_state(options.state == "open"     ? v1::LOAD_STATE_OPEN
                      : options.state == "closed" ? v1::LOAD_STATE_CLOSED
                                                  : v1::LOAD_STATE_UNSPECIFIED);
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::ListLoadsResponse all;
    // Newest first, page after page, until --limit.
    while (all.loads_size() < options.limit) {
        request.set_page_size(std::min(1000, options.limit - all.loads_size()));
        v1::ListLoadsResponse page;
        const auto context = connection.NewContext();
        const grpc::Status status = connection.Soil().ListLoads(context.get(), request, &page);
        if (!status.ok()) return ReportRpcError(status);
        all.mutable_loads()->MergeFrom(page.loads());
        if (page.next_page_token().empty()) break;
        request.set_page_token(page.next_page_token());
    }
    PrintLoadList(all, global.json, std::cout);
    return kExitOk;
}

struct WatchOptions {
    std::string haul_unit, container, after;
    int count = 0;
};

/// Prints each change of a load as a line until interrupted (or --count events), resuming after
/// the last one printed when the server ends the watch.
int RunWatch(const WatchOptions& options, const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::WatchLoadsRequest request;
    request.set_haul_unit_id(options.haul_unit);
    request.set_container_id(options.container);
    request.set_after_event_id(options.after);
    return RunResumableWatch<v1::LoadEvent>(
        connection, request, options.count,
        [](auto& soil, auto* context, const auto& r) { return soil.WatchLoads(context, r); },
        [&global](const v1::LoadEvent& event) {
            PrintLoadEventLine(event, global.json, std::cout);
        },
        [](v1::WatchLoadsRequest& r, const v1::LoadEvent& event) {
            r.set_after_event_id(event.event_id());
        });
}

}  // namespace

void AddLoadsCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto* group = app.add_subcommand("loads", "truck loads filled by bucket passes");
    group->require_subcommand(1);

    auto create = std::make_shared<CreateOptions>();
    auto* create_command =
        group->add_subcommand("create", "open a load (closes the haul unit's open one)");
    create_command->add_option("--haul-unit", create->haul_unit, "the truck's fleet id")
        ->required();
    create_command->add_option("--id", create->id, "load id (default: the server picks one)");
    create_command->add_option("--body", create->body, "the truck body's container id");
    auto* m3 = create_command->add_option("--target-m3", create->target_m3, "target volume [m^3]")
                   ->check(CLI::PositiveNumber);
    create_command->add_option("--target-kg", create->target_kg, "target payload [kg]")
        ->check(CLI::PositiveNumber)
        ->excludes(m3);
    create_command->add_option("--display-name", create->display_name, "for people");
    create_command->add_option("--request-id", create->request_id,
                               "makes a retry return the first result");
    create_command->callback(
        [create, &global, exit_code] { *exit_code = RunCreate(*create, global); });

    auto id = std::make_shared<std::string>();
    auto* get = group->add_subcommand("get", "one load with its passes");
    get->add_option("load", *id, "load id")->required();
    get->callback([id, &global, exit_code] { *exit_code = RunGet(*id, global); });

    auto close = std::make_shared<std::pair<std::string, std::string>>();
    auto* close_command = group->add_subcommand("close", "close an open load");
    close_command->add_option("load", close->first, "load id")->required();
    close_command->add_option("--etag", close->second, "only if the load is at this etag");
    close_command->callback([close, &global, exit_code] {
        *exit_code = RunClose(close->first, close->second, global);
    });

    auto list = std::make_shared<ListOptions>();
    auto* list_command = group->add_subcommand("list", "loads, newest first");
    list_command->add_option("--haul-unit", list->haul_unit, "only this haul unit's");
    list_command->add_option("--state", list->state, "open or closed")
        ->check(CLI::IsMember({"open", "closed"}));
    list_command->add_option("--limit", list->limit, "at most this many")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    list_command->callback([list, &global, exit_code] { *exit_code = RunList(*list, global); });

    auto watch = std::make_shared<WatchOptions>();
    auto* watch_command = group->add_subcommand(
        "watch", "print each change of a load as it is committed (Ctrl-C ends)");
    watch_command->add_option("--haul-unit", watch->haul_unit, "only this haul unit's loads");
    watch_command->add_option("--container", watch->container,
                              "only this container's events (its passes or body scans)");
    watch_command->add_option("--after", watch->after, "resume after this event id");
    watch_command->add_option("--count", watch->count, "end after this many events")
        ->check(CLI::NonNegativeNumber);
    watch_command->callback([watch, &global, exit_code] { *exit_code = RunWatch(*watch, global); });
}

}  // namespace soilvol::client
