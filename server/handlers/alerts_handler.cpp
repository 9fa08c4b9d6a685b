// Alerts: what estimates and loads raise under their rules, listed and watched; the webhooks
// the server posts them to, with their delivery log.
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/logging.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

constexpr int kLoadsJudgedPerRound = 100;

v1::WebhookDelivery ToDelivery(const DeliveryRecord& row) {
    v1::WebhookDelivery out;
    out.set_delivery_id(absl::StrCat(row.id));
    out.set_webhook_id(row.webhook_id);
    out.set_alert_id(absl::StrCat(row.alert_id));
    out.set_attempt(row.attempt);
    *out.mutable_time() = TimeUtil::MicrosecondsToTimestamp(row.time_us);
    out.set_outcome(v1::DeliveryOutcome_IsValid(row.outcome)
                        ? static_cast<v1::DeliveryOutcome>(row.outcome)
                        : v1::DELIVERY_OUTCOME_UNSPECIFIED);
    out.set_http_status(row.http_status);
    out.set_error(row.error);
    out.set_latency_ms(row.latency_ms);
    out.set_delay_ms(row.delay_ms);
    return out;
}

/// The state's figures into the configured webhook.
void AddState(const WebhookState& state, v1::Webhook* out) {
    out->set_delivered_through_alert_id(absl::StrCat(state.cursor));
    out->set_pending_alerts(state.pending);
    if (state.last_delivery_us > 0) {
        *out->mutable_last_delivery_time() =
            TimeUtil::MicrosecondsToTimestamp(state.last_delivery_us);
    }
    out->set_failing_attempts(state.failing_attempts);
    out->set_last_error(state.last_error);
    if (state.next_attempt_us > 0) {
        *out->mutable_next_attempt_time() =
            TimeUtil::MicrosecondsToTimestamp(state.next_attempt_us);
    }
}

}  // namespace

absl::Status SoilVolumeHandlers::ListAlerts(const v1::ListAlertsRequest& request,
                                            v1::ListAlertsResponse* response, CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    AlertQuery query;
    if (!request.container_id().empty() && request.container_id() != "-") {
        SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
        query.container_id = request.container_id();
    }
    if (!v1::AlertKind_IsValid(request.kind())) {
        return absl::InvalidArgumentError(absl::StrCat("kind: unknown value ", request.kind()));
    }
    query.kind = request.kind();
    SOILVOL_RETURN_IF_ERROR(
        TimeRangeMicros(request.has_start_time() ? &request.start_time() : nullptr,
                        request.has_end_time() ? &request.end_time() : nullptr,
                        &query.start_time_us, &query.end_time_us));
    SOILVOL_ASSIGN_OR_RETURN(const int size, PageSizeOf(request.page_size()));
    SOILVOL_ASSIGN_OR_RETURN(query.before_id, ParseRecordPageToken(request.page_token()));
    query.limit = size + 1;  // one more tells whether there is a next page
    SOILVOL_ASSIGN_OR_RETURN(std::vector<AlertRecord> rows, store->ListAlerts(query));
    const bool more = rows.size() > static_cast<std::size_t>(size);
    if (more) rows.resize(static_cast<std::size_t>(size));
    for (const AlertRecord& row : rows) *response->add_alerts() = ToAlert(row);
    if (more && !rows.empty()) response->set_next_page_token(RecordPageToken(rows.back().id));
    return absl::OkStatus();
}

absl::StatusOr<std::function<void()>> SoilVolumeHandlers::WatchAlerts(
    const v1::WatchAlertsRequest& request, AlertDeliver deliver, WatchEnded ended) {
    SOILVOL_RETURN_IF_ERROR(LoadStore().status());
    AlertFeed::Spec spec;
    if (!request.container_id().empty() && request.container_id() != "-") {
        SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
        spec.container_id = request.container_id();
    }
    if (!request.after_alert_id().empty()) {
        SOILVOL_ASSIGN_OR_RETURN(spec.after_id,
                                 ParseResumeId(request.after_alert_id(), "after_alert_id"));
    }
    auto converted = [deliver = std::move(deliver)](const AlertRecord* row) {
        if (row == nullptr) return deliver(nullptr);
        const v1::Alert alert = ToAlert(*row);
        return deliver(&alert);
    };
    SOILVOL_ASSIGN_OR_RETURN(
        std::shared_ptr<AlertFeed::Watch> watch,
        alert_feed_->Start(std::move(spec), std::move(converted), std::move(ended)));
    AlertFeed* feed = alert_feed_;
    return std::function<void()>([feed, watch] { feed->Stop(watch); });
}

absl::Status SoilVolumeHandlers::ListWebhooks(const v1::ListWebhooksRequest&,
                                              v1::ListWebhooksResponse* response, CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    std::vector<std::string> ids;
    for (const v1::Webhook& webhook : options_.webhooks) ids.push_back(webhook.webhook_id());
    SOILVOL_ASSIGN_OR_RETURN(const std::vector<WebhookState> states, store->WebhookStates(ids));
    for (const v1::Webhook& webhook : options_.webhooks) {
        v1::Webhook* out = response->add_webhooks();
        *out = webhook;
        for (const WebhookState& state : states) {
            if (state.webhook_id == webhook.webhook_id()) AddState(state, out);
        }
    }
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::ListWebhookDeliveries(
    const v1::ListWebhookDeliveriesRequest& request, v1::ListWebhookDeliveriesResponse* response,
    CallRecord&) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    DeliveryQuery query;
    if (request.webhook_id() != "-") {
        bool known = false;
        for (const v1::Webhook& webhook : options_.webhooks) {
            known = known || webhook.webhook_id() == request.webhook_id();
        }
        if (!known) {
            return absl::NotFoundError(absl::StrCat("webhook_id: no webhook '",
                                                    request.webhook_id(),
                                                    "' is configured (--webhooks-file)"));
        }
        query.webhook_id = request.webhook_id();
    }
    if (!request.alert_id().empty()) {
        SOILVOL_ASSIGN_OR_RETURN(query.alert_id, ParseRecordId(request.alert_id(), "alert_id"));
    }
    SOILVOL_ASSIGN_OR_RETURN(const int size, PageSizeOf(request.page_size()));
    SOILVOL_ASSIGN_OR_RETURN(query.before_id, ParseRecordPageToken(request.page_token()));
    query.limit = size + 1;
    SOILVOL_ASSIGN_OR_RETURN(std::vector<DeliveryRecord> rows, store->ListDeliveries(query));
    const bool more = rows.size() > static_cast<std::size_t>(size);
    if (more) rows.resize(static_cast<std::size_t>(size));
    for (const DeliveryRecord& row : rows) *response->add_deliveries() = ToDelivery(row);
    if (more && !rows.empty()) response->set_next_page_token(RecordPageToken(rows.back().id));
    return absl::OkStatus();
}

absl::StatusOr<int> SoilVolumeHandlers::JudgeLoads(std::int64_t now_us) {
    SOILVOL_ASSIGN_OR_RETURN(RecordStore * store, LoadStore());
    const std::int64_t idle_before = options_.load_idle_us > 0
                                         ? now_us - options_.load_idle_us
                                         : std::numeric_limits<std::int64_t>::min();
    SOILVOL_ASSIGN_OR_RETURN(const std::vector<std::string> ids,
                             store->UnjudgedLoads(idle_before, kLoadsJudgedPerRound));
    int judged = 0;
    for (const std::string& id : ids) {
        // An idle one is closed first (kIdle, at its last activity plus the idle time).
        SOILVOL_ASSIGN_OR_RETURN(const LoadRecord row,
                                 store->CloseLoad(id, now_us, options_.load_idle_us, std::nullopt));
        if (row.state != LoadRecord::kClosed) continue;  // a pass came meanwhile
        v1::Load load;
        SOILVOL_RETURN_IF_ERROR(BuildLoads({row}, {&load}));
        const v1::Container* body = nullptr;
        std::shared_ptr<const ContainerEntry> body_entry;
        if (!row.body_container_id.empty()) {
            auto found = LoadContainer(row.body_container_id, "body_container_id");
            if (found.ok()) body_entry = *std::move(found);
            if (body_entry != nullptr) body = &body_entry->info;
        }
        std::optional<AlertRecord> alert;
        if (auto raised = LoadAlert(RulesFor(body, options_.alert_rules), load, now_us)) {
            alert = ToAlertRecord(*raised);
        }
        SOILVOL_ASSIGN_OR_RETURN(const bool mine, store->JudgeLoad(id, alert));
        if (!mine) continue;
        ++judged;
        std::lock_guard<std::mutex> lock(judge_mutex_);
        const int status = load.assessment().status();
        if (status >= 0 && status < static_cast<int>(judged_.loads_closed.size())) {
            ++judged_.loads_closed[static_cast<std::size_t>(status)];
        }
        judged_.load_alerts += alert ? 1 : 0;
    }
    return judged;
}

SoilVolumeHandlers::JudgeFigures SoilVolumeHandlers::judge_figures() const {
    std::lock_guard<std::mutex> lock(judge_mutex_);
    return judged_;
}

void SoilVolumeHandlers::JudgeClosed() {
    if (recorder_ == nullptr) return;
    const absl::StatusOr<int> judged = JudgeLoads(NowMicros());
    if (!judged.ok()) {  // the sweeper tries again within a second
        LogEvent(LogLevel::kWarn, "judging closed loads failed",
                 {{"error", judged.status().message()}});
    }
}

void SoilVolumeHandlers::CountRefusal(const v1::EstimateVolumeRequest& request,
                                      const v1::Container& container, const absl::Status& refused) {
    if (!Records(request) || !absl::IsFailedPrecondition(refused)) return;
    std::optional<Refusal> refusal =
        RefusalOf(RulesFor(&container, options_.alert_rules), request.container_id(),
                  request.request_id(), refused, NowMicros());
    EstimateRecord row;
    row.container_id = request.container_id();
    row.create_time_us = NowMicros();
    row.request_id = request.request_id();
    row.refusal = refusal ? *std::move(refusal) : Refusal{};
    recorder_->RecordAsync(std::move(row), [](const absl::StatusOr<std::int64_t>&) {});
}

}  // namespace soilvol::server
