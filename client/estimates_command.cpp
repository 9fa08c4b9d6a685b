#include <google/protobuf/util/time_util.h>

#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.hpp"
#include "client/input_files.hpp"
#include "client/response_printer.hpp"
#include "client/watch_loop.hpp"

namespace soilvol::client {
namespace {

struct ListOptions {
    std::string container = "-";
    std::string registration;  ///< "" the container's current one, "-" every one
    std::string since, until;  ///< RFC 3339
    int limit = 100;
    bool full = false;
};

absl::Status ParseTime(const std::string& text, const char* flag,
                       google::protobuf::Timestamp* out) {
    if (!google::protobuf::util::TimeUtil::FromString(text, out)) {
        return absl::InvalidArgumentError(
            absl::StrCat(flag, ": '", text, "' is not an RFC 3339 time (2026-12-04T06:00:00Z)"));
    }
    return absl::OkStatus();
}

int RunList(const ListOptions& options, const GlobalOptions& global) {
    v1::ListEstimatesRequest request;
    request.set_container_id(options.container);
    request.set_registration_id(options.registration);
    request.set_view(options.full ? v1::ESTIMATE_VIEW_FULL : v1::ESTIMATE_VIEW_BASIC);
    if (!options.since.empty()) {
        if (absl::Status s = ParseTime(options.since, "--since", request.mutable_start_time());
            !s.ok()) {
            return ReportUsageError(s);
        }
    }
    if (!options.until.empty()) {
        if (absl::Status s = ParseTime(options.until, "--until", request.mutable_end_time());
            !s.ok()) {
            return ReportUsageError(s);
        }
    }
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    std::vector<v1::Estimate> estimates;
    // Newest first, page after page, until --limit.
    while (static_cast<int>(estimates.size()) < options.limit) {
        request.set_page_size(std::min(1000, options.limit - static_cast<int>(estimates.size())));
        v1::ListEstimatesResponse page;
        const auto context = connection.NewContext();
        const grpc::Status status = connection.Soil().ListEstimates(context.get(), request, &page);
        if (!status.ok()) return ReportRpcError(status);
        estimates.insert(estimates.end(), page.estimates().begin(), page.estimates().end());
        if (page.next_page_token().empty()) break;
        request.set_page_token(page.next_page_token());
    }
    PrintEstimateList(estimates, global.json, std::cout);
    return kExitOk;
}

int RunGet(const std::string& container, const std::string& id, const GlobalOptions& global) {
    v1::GetEstimateRequest request;
    request.set_container_id(container);
    request.set_estimate_id(id);
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    const auto context = connection.NewContext();
    v1::Estimate estimate;
    const grpc::Status status = connection.Soil().GetEstimate(context.get(), request, &estimate);
    if (!status.ok()) return ReportRpcError(status);
    PrintEstimateRecord(estimate, global.json, std::cout);
    return kExitOk;
}

/// Prints each new record as a line until interrupted (or --count records), resuming after
/// --after when given; a watch the server ends is reopened after the last id printed.
int RunWatch(const std::string& container, const std::string& after, int count,
             const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::WatchEstimatesRequest request;
    request.set_container_id(container);
    request.set_after_estimate_id(after);
    return RunResumableWatch<v1::Estimate>(
        connection, request, count,
        [](auto& soil, auto* context, const auto& r) { return soil.WatchEstimates(context, r); },
        [&global](const v1::Estimate& estimate) {
            PrintEstimateLine(estimate, global.json, std::cout);
        },
        [](v1::WatchEstimatesRequest& r, const v1::Estimate& estimate) {
            r.set_after_estimate_id(estimate.estimate_id());
        });
}

}  // namespace

void AddEstimatesCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto* group = app.add_subcommand("estimates", "the records of answered estimates");
    group->require_subcommand(1);

    auto list = std::make_shared<ListOptions>();
    auto* list_command = group->add_subcommand("list", "records, newest first");
    list_command->add_option("--container", list->container, "container id; - for every one")
        ->capture_default_str();
    list_command->add_option("--registration", list->registration,
                             "a registration id; - for every one (default: the container's "
                             "current registration)");
    list_command->add_option("--since", list->since, "from this RFC 3339 time");
    list_command->add_option("--until", list->until, "before this RFC 3339 time");
    list_command->add_option("--limit", list->limit, "at most this many")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    list_command->add_flag("--full", list->full, "with heightmaps (JSON output)");
    list_command->callback([list, &global, exit_code] { *exit_code = RunList(*list, global); });

    auto ids = std::make_shared<std::pair<std::string, std::string>>();
    auto* get = group->add_subcommand("get", "one record in full");
    get->add_option("container", ids->first, "container id")->required();
    get->add_option("estimate", ids->second, "estimate id")->required();
    get->callback(
        [ids, &global, exit_code] { *exit_code = RunGet(ids->first, ids->second, global); });

    struct WatchOptions {
        std::string container, after;
        int count = 0;
    };
    auto watch = std::make_shared<WatchOptions>();
    auto* watch_command =
        group->add_subcommand("watch", "print each new record as it is committed (Ctrl-C ends)");
    watch_command->add_option("--container", watch->container, "container id (default: all)");
    watch_command->add_option("--after", watch->after, "resume after this estimate id");
    watch_command->add_option("--count", watch->count, "end after this many records")
        ->check(CLI::NonNegativeNumber);
    watch_command->callback([watch, &global, exit_code] {
        *exit_code = RunWatch(watch->container, watch->after, watch->count, global);
    });
}

}  // namespace soilvol::client
