#include "server/webhooks/webhook_dispatcher.hpp"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "google/protobuf/util/json_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/logging.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/webhooks/webhook_signature.hpp"

namespace soilvol::server {
namespace {

constexpr int kAlertsPerRead = 50;
constexpr std::size_t kMaxErrorBytes = 300;

/// What a failed attempt logs: the transport's error, or the status with the body's start.
std::string FailureOf(const PostResult& result) {
    std::string error = result.error;
    if (error.empty()) {
        error = absl::StrCat("HTTP ", result.status_code);
        if (!result.body_excerpt.empty()) absl::StrAppend(&error, ": ", result.body_excerpt);
    }
    if (error.size() > kMaxErrorBytes) error.resize(kMaxErrorBytes);
    return error;
}

}  // namespace

std::string AlertJson(const AlertRecord& alert) {
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(ToAlert(alert), &json).ok()) return "{}";
    return json;
}

std::vector<std::pair<std::string, std::string>> WebhookHeaders(const WebhookTarget& target,
                                                                const AlertRecord& alert,
                                                                const std::string& body,
                                                                int attempt,
                                                                std::int64_t unix_seconds) {
    std::vector<std::pair<std::string, std::string>> headers = {
        {"Idempotency-Key", absl::StrCat(alert.id)},
        {"Soilvol-Event", AlertKindLabel(alert.kind)},
        {"Soilvol-Webhook", target.config.webhook_id()},
        {"Soilvol-Delivery-Attempt", absl::StrCat(attempt)},
    };
    if (!target.secret.empty()) {
        headers.emplace_back("Soilvol-Signature",
                             SignatureHeader(target.secret, unix_seconds, body));
    }
    return headers;
}

WebhookDispatcher::WebhookDispatcher(EstimateRecorder& recorder, std::vector<WebhookTarget> targets,
                                     Config config)
    : recorder_(recorder),
      targets_(std::move(targets)),
      config_(std::move(config)),
      random_(std::random_device{}()) {
    for (std::size_t i = 0; i < targets_.size(); ++i) {
        threads_.emplace_back([this, i] { Run(i); });
    }
}

WebhookDispatcher::~WebhookDispatcher() { Shutdown(); }

void WebhookDispatcher::Shutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    stop_cv_.notify_all();
    recorder_.WakeWaiters();
    for (std::thread& thread : threads_) {
        if (thread.joinable()) thread.join();
    }
}

std::map<std::string, WebhookDispatcher::Counts> WebhookDispatcher::counts() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return counts_;
}

bool WebhookDispatcher::Sleep(std::chrono::milliseconds delay) {
    std::unique_lock<std::mutex> lock(mutex_);
    stop_cv_.wait_for(lock, delay, [this] { return stopping_; });
    return !stopping_;
}

double WebhookDispatcher::Jitter() {
    std::lock_guard<std::mutex> lock(mutex_);
    return std::uniform_real_distribution<double>(0.0, 1.0)(random_);
}

void WebhookDispatcher::Run(std::size_t index) {
    const WebhookTarget& target = targets_[index];
    std::int64_t seen = 0;
    while (true) {
        bool stopping = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stopping = stopping_;
        }
        if (stopping) break;
        const std::optional<std::chrono::milliseconds> wait = Step(target);
        if (!wait) {
            seen = recorder_.WaitForNewer(seen, config_.poll);  // a commit here, or the poll
        } else if (wait->count() > 0 && !Sleep(*wait)) {
            break;
        }
    }
    // Another replica takes over now rather than when the lease lapses (a rolling restart).
    recorder_.store().ReleaseWebhook(target.config.webhook_id(), config_.holder).IgnoreError();
}

std::optional<std::chrono::milliseconds> WebhookDispatcher::Step(const WebhookTarget& target) {
    using std::chrono::milliseconds;
    RecordStore& store = recorder_.store();
    const std::string& id = target.config.webhook_id();
    const std::int64_t lease_us =
        std::chrono::duration_cast<std::chrono::microseconds>(config_.lease).count();
    std::int64_t now_us = NowMicros();
    absl::StatusOr<std::optional<WebhookState>> leased =
        store.LeaseWebhook(id, config_.holder, now_us, now_us + lease_us);
    if (!leased.ok()) {
        LogEvent(LogLevel::kWarn, "webhook: the records database is away",
                 {{"webhook", id}, {"error", leased.status().message()}});
        return milliseconds(1000);
    }
    if (!leased->has_value()) return milliseconds(1000);  // another replica sends
    WebhookState state = **leased;
    if (state.next_attempt_us > now_us) {
        return milliseconds(
            std::min<std::int64_t>((state.next_attempt_us - now_us) / 1000 + 1, lease_us / 2000));
    }
    AlertQuery query;
    query.after_id = state.cursor;
    query.limit = kAlertsPerRead;
    absl::StatusOr<std::vector<AlertRecord>> alerts = store.ListAlerts(query);
    if (!alerts.ok()) return milliseconds(1000);
    const std::int64_t start_cursor = state.cursor;
    for (const AlertRecord& alert : *alerts) {
        if (!Accepts(target, alert.kind, alert.container_id)) {
            state.cursor = alert.id;
            continue;
        }
        DeliveryRecord attempt;
        Attempt(target, alert, state, attempt);
        if (absl::Status saved = store.SaveWebhook(config_.holder, state, &attempt); !saved.ok()) {
            return milliseconds(1000);  // lost the lease or the database: start again
        }
        return state.cursor == alert.id ? milliseconds(0)
                                        : milliseconds(std::max<std::int64_t>(
                                              0, (state.next_attempt_us - NowMicros()) / 1000));
    }
    if (state.cursor != start_cursor) {
        store.SaveWebhook(config_.holder, state, nullptr).IgnoreError();  // skipped to here
    }
    if (static_cast<int>(alerts->size()) == kAlertsPerRead) return milliseconds(0);
    return std::nullopt;
}

void WebhookDispatcher::Attempt(const WebhookTarget& target, const AlertRecord& alert,
                                WebhookState& state, DeliveryRecord& attempt) {
    attempt.webhook_id = target.config.webhook_id();
    attempt.alert_id = alert.id;
    attempt.attempt = state.failing_attempts + 1;
    const std::int64_t max_age_us =
        std::chrono::duration_cast<std::chrono::microseconds>(config_.max_age).count();
    std::int64_t now_us = NowMicros();
    if (now_us - alert.create_time_us > max_age_us) {
        attempt.outcome = DeliveryRecord::kAbandoned;
        attempt.error = absl::StrCat("older than ", config_.max_age.count() / 3600, " h");
    } else {
        const std::string body = AlertJson(alert);
        const PostResult result = PostJson(
            target.url, WebhookHeaders(target, alert, body, attempt.attempt, now_us / 1'000'000),
            body, config_.post);
        now_us = NowMicros();
        attempt.http_status = result.status_code;
        attempt.latency_ms = static_cast<double>(result.latency.count());
        const bool delivered =
            result.error.empty() && result.status_code >= 200 && result.status_code < 300;
        attempt.outcome = delivered ? DeliveryRecord::kDelivered : DeliveryRecord::kFailed;
        if (!delivered) attempt.error = FailureOf(result);
    }
    attempt.time_us = now_us;
    attempt.delay_ms = static_cast<double>(now_us - alert.create_time_us) / 1000.0;
    Counts counts;
    if (attempt.outcome == DeliveryRecord::kFailed) {
        ++state.failing_attempts;
        state.last_error = attempt.error;
        state.next_attempt_us =
            now_us + RetryDelay(config_.backoff, state.failing_attempts, Jitter()).count() * 1000;
        counts.failed = 1;
    } else {
        state.cursor = alert.id;
        state.failing_attempts = 0;
        state.next_attempt_us = 0;
        if (attempt.outcome == DeliveryRecord::kDelivered) {
            state.last_delivery_us = now_us;
            state.last_error.clear();
            counts.delivered = 1;
        } else {
            state.last_error = attempt.error;
            counts.abandoned = 1;
        }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    Counts& total = counts_[attempt.webhook_id];
    total.delivered += counts.delivered;
    total.failed += counts.failed;
    total.abandoned += counts.abandoned;
}

}  // namespace soilvol::server
