#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "absl/status/status.h"

namespace soilvol::server {

/// An alert as kept (soilvol.v1.Alert): kinds are the proto's AlertKind numbers.
struct AlertRecord {
    static constexpr int kOverload = 1, kCarryback = 2, kRefusedScans = 3, kLowCoverage = 4,
                         kLoadOffTarget = 5;

    std::int64_t id = 0;  ///< set by the store: increasing in commit order, as estimate ids
    int kind = 0;
    std::int64_t create_time_us = 0;
    std::string container_id;
    std::int64_t estimate_id = 0;  ///< set by Append for an estimate's alert; 0 for none
    std::string load_id, haul_unit_id, request_id;
    std::string message;
    double value = 0.0, threshold = 0.0;
};

/// Which alerts a ListAlerts returns: newest first below before_id, or (with after_id) oldest
/// first above it.
struct AlertQuery {
    std::string container_id;  ///< "" for every container
    int kind = 0;              ///< 0 for every kind
    std::optional<std::int64_t> before_id, after_id;
    std::int64_t start_time_us = std::numeric_limits<std::int64_t>::min();  ///< inclusive
    std::int64_t end_time_us = std::numeric_limits<std::int64_t>::max();    ///< exclusive
    int limit = 100;
};

/// A scan of a container refused (FAILED_PRECONDITION): not kept, but counted in its
/// container's run of refusals, which a kept record of the container ends. `alert` is raised
/// (kept) when the run reaches alert_after (0: never).
struct Refusal {
    int alert_after = 0;
    AlertRecord alert;  ///< its message gets the run's length appended
};

/// A webhook's place in the alerts and its delivery state (soilvol.v1.Webhook's output).
struct WebhookState {
    std::string webhook_id;
    std::int64_t cursor = 0;   ///< every alert up to it was delivered or abandoned
    std::int64_t pending = 0;  ///< alerts after the cursor (WebhookStates only)
    std::int64_t last_delivery_us = 0;
    int failing_attempts = 0;
    std::string last_error;
    std::int64_t next_attempt_us = 0;
};

/// One attempt to post an alert to a webhook (soilvol.v1.WebhookDelivery; outcomes are
/// DeliveryOutcome's numbers).
struct DeliveryRecord {
    static constexpr int kDelivered = 1, kFailed = 2, kAbandoned = 3;
    std::int64_t id = 0;  ///< set by the store
    std::string webhook_id;
    std::int64_t alert_id = 0;
    int attempt = 1;
    std::int64_t time_us = 0;
    int outcome = kFailed;
    int http_status = 0;
    std::string error;
    double latency_ms = 0.0, delay_ms = 0.0;
};

/// Which attempts ListDeliveries returns, newest first.
struct DeliveryQuery {
    std::string webhook_id;     ///< "" for every webhook
    std::int64_t alert_id = 0;  ///< 0 for every alert
    std::optional<std::int64_t> before_id;
    int limit = 100;
};

/// Aborted: `holder` lost the lease of the webhook (another replica sends now).
absl::Status LostLease(const std::string& webhook_id);

}  // namespace soilvol::server
