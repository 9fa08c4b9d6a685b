#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "server/records/recorder.hpp"
#include "server/webhooks/retry_backoff.hpp"
#include "server/webhooks/webhook_config.hpp"
#include "server/webhooks/webhook_post.hpp"

namespace soilvol::server {

/// Posts the alerts kept in the records database to the configured webhooks (see
/// soilvol.v1.Webhook): one thread per webhook sends its alerts one at a time in id order, from
/// the position kept in the database (so nothing is lost across a restart), under a lease there
/// (so one replica sends at a time; another takes over when it lapses). Each attempt is logged;
/// a failure waits a backoff with jitter before the same alert is tried again, until it is
/// older than max_age (abandoned). Delivery is at least once: a retry, or a replica that takes
/// over after a lapsed lease, may post an alert again, always under the same Idempotency-Key.
class WebhookDispatcher {
  public:
    struct Config {
        RetryBackoff backoff;
        PostOptions post;
        std::chrono::seconds max_age{72 * 3600};  ///< --webhook-max-age-hours
        std::chrono::milliseconds poll{250};      ///< for other replicas' alerts
        std::chrono::seconds lease{30};
        std::string holder;  ///< names this process in the leases
    };
    struct Counts {
        std::uint64_t delivered = 0, failed = 0, abandoned = 0;
    };

    WebhookDispatcher(EstimateRecorder& recorder, std::vector<WebhookTarget> targets,
                      Config config);
    /// Shutdown.
    ~WebhookDispatcher();
    WebhookDispatcher(const WebhookDispatcher&) = delete;
    WebhookDispatcher& operator=(const WebhookDispatcher&) = delete;

    /// Stops every thread (after the post in flight, if any), each giving up its lease.
    void Shutdown();

    /// Attempts by webhook and outcome since the start (for /metrics).
    std::map<std::string, Counts> counts() const;

  private:
    /// One webhook's loop.
    void Run(std::size_t index);
    /// One step of a webhook: at most one alert posted (the alerts it does not take skipped).
    /// How long to wait before the next step; zero: at once; nullopt: nothing to send, wait for
    /// a new alert.
    std::optional<std::chrono::milliseconds> Step(const WebhookTarget& target);
    /// Posts `alert` and writes the outcome into `state` and `attempt`.
    void Attempt(const WebhookTarget& target, const AlertRecord& alert, WebhookState& state,
                 DeliveryRecord& attempt);
    /// Waits `delay` unless stopping; false when stopping.
    bool Sleep(std::chrono::milliseconds delay);
    double Jitter();

    EstimateRecorder& recorder_;
    const std::vector<WebhookTarget> targets_;
    const Config config_;
    mutable std::mutex mutex_;
    std::condition_variable stop_cv_;
    bool stopping_ = false;
    std::map<std::string, Counts> counts_;
    std::mt19937_64 random_;
    std::vector<std::thread> threads_;
};

/// The JSON an alert is posted as (soilvol.v1.Alert in the proto3 JSON mapping, as the REST
/// API returns it).
std::string AlertJson(const AlertRecord& alert);

/// The headers of an attempt at `alert`, signed with `secret` (none when empty) at
/// `unix_seconds`.
std::vector<std::pair<std::string, std::string>> WebhookHeaders(const WebhookTarget& target,
                                                                const AlertRecord& alert,
                                                                const std::string& body,
                                                                int attempt,
                                                                std::int64_t unix_seconds);

}  // namespace soilvol::server
