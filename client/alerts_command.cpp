// soilvol alerts list|watch, soilvol webhooks list|deliveries.
#include <iostream>
#include <memory>
#include <string>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "client/commands.hpp"
#include "client/response_printer.hpp"
#include "client/table.hpp"
#include "client/watch_loop.hpp"
#include "google/protobuf/util/json_util.h"

namespace soilvol::client {
namespace {

std::vector<std::string> AlertCells(const v1::Alert& alert) {
    return {alert.alert_id(),
            TimeText(alert.create_time()),
            EnumLabel(v1::AlertKind_Name(alert.kind()), "ALERT_KIND_"),
            alert.container_id().empty() ? "-" : alert.container_id(),
            alert.load_id().empty() ? "-" : alert.load_id(),
            alert.message()};
}

void PrintAlertLine(const v1::Alert& alert, bool json, std::ostream& out) {
    if (json) {
        std::string line;
        if (!google::protobuf::util::MessageToJsonString(alert, &line).ok()) line = "{}";
        out << line << std::endl;
        return;
    }
    const std::vector<std::string> cells = AlertCells(alert);
    out << cells[0] << "  " << cells[1] << "  " << cells[2] << "  " << cells[5] << std::endl;
}

struct AlertListOptions {
    std::string container, kind;
    int limit = 100;
};

int RunAlertList(const AlertListOptions& options, const GlobalOptions& global) {
    v1::ListAlertsRequest request;
    request.set_container_id(options.container);
    if (!options.kind.empty()) {
        v1::AlertKind kind = v1::ALERT_KIND_UNSPECIFIED;
        v1::AlertKind_Parse("ALERT_KIND_" + absl::AsciiStrToUpper(options.kind), &kind);
        request.set_kind(kind);
    }
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::ListAlertsResponse all;
    while (all.alerts_size() < options.limit) {
        request.set_page_size(std::min(1000, options.limit - all.alerts_size()));
        v1::ListAlertsResponse page;
        const auto context = connection.NewContext();
        const grpc::Status status = connection.Soil().ListAlerts(context.get(), request, &page);
        if (!status.ok()) return ReportRpcError(status);
        all.mutable_alerts()->MergeFrom(page.alerts());
        if (page.next_page_token().empty()) break;
        request.set_page_token(page.next_page_token());
    }
    if (global.json) {
        PrintJson(all, std::cout);
        return kExitOk;
    }
    Table table({"id", "time", "kind", "container", "load", "message"});
    for (const v1::Alert& alert : all.alerts()) table.AddRow(AlertCells(alert));
    table.Print(std::cout);
    return kExitOk;
}

/// Prints each new alert as a line until interrupted (or --count alerts), resuming after the
/// last one printed when the server ends the watch.
int RunAlertWatch(const std::string& container, const std::string& after, int count,
                  const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::WatchAlertsRequest request;
    request.set_container_id(container);
    request.set_after_alert_id(after);
    return RunResumableWatch<v1::Alert>(
        connection, request, count,
        [](auto& soil, auto* context, const auto& r) { return soil.WatchAlerts(context, r); },
        [&global](const v1::Alert& alert) { PrintAlertLine(alert, global.json, std::cout); },
        [](v1::WatchAlertsRequest& r, const v1::Alert& alert) {
            r.set_after_alert_id(alert.alert_id());
        });
}

int RunWebhooks(const GlobalOptions& global) {
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::ListWebhooksResponse response;
    const auto context = connection.NewContext();
    const grpc::Status status =
        connection.Soil().ListWebhooks(context.get(), v1::ListWebhooksRequest(), &response);
    if (!status.ok()) return ReportRpcError(status);
    if (global.json) {
        PrintJson(response, std::cout);
        return kExitOk;
    }
    Table table({"webhook", "url", "delivered through", "pending", "failing", "last error"});
    for (const v1::Webhook& hook : response.webhooks()) {
        table.AddRow({hook.webhook_id(), hook.url(), hook.delivered_through_alert_id(),
                      absl::StrCat(hook.pending_alerts()), absl::StrCat(hook.failing_attempts()),
                      hook.last_error().empty() ? "-" : hook.last_error()});
    }
    table.Print(std::cout);
    return kExitOk;
}

struct DeliveryOptions {
    std::string webhook = "-", alert;
    int limit = 100;
};

int RunDeliveries(const DeliveryOptions& options, const GlobalOptions& global) {
    v1::ListWebhookDeliveriesRequest request;
    request.set_webhook_id(options.webhook);
    request.set_alert_id(options.alert);
    request.set_page_size(std::min(options.limit, 1000));
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::ListWebhookDeliveriesResponse response;
    const auto context = connection.NewContext();
    const grpc::Status status =
        connection.Soil().ListWebhookDeliveries(context.get(), request, &response);
    if (!status.ok()) return ReportRpcError(status);
    if (global.json) {
        PrintJson(response, std::cout);
        return kExitOk;
    }
    Table table({"id", "time", "webhook", "alert", "attempt", "outcome", "http", "ms", "error"});
    for (const v1::WebhookDelivery& d : response.deliveries()) {
        table.AddRow({d.delivery_id(), TimeText(d.time()), d.webhook_id(), d.alert_id(),
                      absl::StrCat(d.attempt()),
                      EnumLabel(v1::DeliveryOutcome_Name(d.outcome()), "DELIVERY_OUTCOME_"),
                      absl::StrCat(d.http_status()), Fixed(d.latency_ms(), 0),
                      d.error().empty() ? "-" : d.error()});
    }
    table.Print(std::cout);
    return kExitOk;
}

}  // namespace

void AddAlertsCommands(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto* alerts = app.add_subcommand("alerts", "what the alert rules raised");
    alerts->require_subcommand(1);
    auto list = std::make_shared<AlertListOptions>();
    auto* list_command = alerts->add_subcommand("list", "alerts, newest first");
    list_command->add_option("--container", list->container, "only this container's");
    list_command->add_option("--kind", list->kind, "only this kind")
        ->check(CLI::IsMember(
            {"overload", "carryback", "refused_scans", "low_coverage", "load_off_target"}));
    list_command->add_option("--limit", list->limit, "at most this many")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    list_command->callback(
        [list, &global, exit_code] { *exit_code = RunAlertList(*list, global); });

    struct AlertWatchOptions {
        std::string container, after;
        int count = 0;
    };
    auto watch = std::make_shared<AlertWatchOptions>();
    auto* watch_command =
        alerts->add_subcommand("watch", "print each new alert as it is raised (Ctrl-C ends)");
    watch_command->add_option("--container", watch->container, "container id (default: all)");
    watch_command->add_option("--after", watch->after, "resume after this alert id");
    watch_command->add_option("--count", watch->count, "end after this many alerts")
        ->check(CLI::NonNegativeNumber);
    watch_command->callback([watch, &global, exit_code] {
        *exit_code = RunAlertWatch(watch->container, watch->after, watch->count, global);
    });

    auto* webhooks = app.add_subcommand("webhooks", "where alerts are posted (--webhooks-file)");
    webhooks->require_subcommand(1);
    webhooks->add_subcommand("list", "the webhooks with their delivery state")
        ->callback([&global, exit_code] { *exit_code = RunWebhooks(global); });
    auto deliveries = std::make_shared<DeliveryOptions>();
    auto* log = webhooks->add_subcommand("deliveries", "the delivery log, newest first");
    log->add_option("webhook", deliveries->webhook, "webhook id; - for every one")
        ->capture_default_str();
    log->add_option("--alert", deliveries->alert, "only the attempts at this alert");
    log->add_option("--limit", deliveries->limit, "at most this many (1000 at most)")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    log->callback(
        [deliveries, &global, exit_code] { *exit_code = RunDeliveries(*deliveries, global); });
}

}  // namespace soilvol::client
