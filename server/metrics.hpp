#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"

namespace soilvol::server {

/// Prometheus metrics of one server (prometheus-cpp, pull model: the REST gateway serves
/// Serialize() on /metrics). Thread-safe.
class Metrics {
  public:
    Metrics();
    ~Metrics();
    Metrics(const Metrics&) = delete;
    Metrics& operator=(const Metrics&) = delete;

    /// soilvol_requests_total{method, code, transport} and
    /// soilvol_request_duration_seconds{method}.
    void RecordRequest(std::string_view method, std::string_view transport, absl::StatusCode code,
                       double seconds);
    /// soilvol_stage_duration_seconds{stage}: decode, rectify, match, reproject, preprocess,
    /// align, volume, queue.
    void RecordStage(std::string_view stage, double seconds);
    /// soilvol_in_flight (running on a worker) and soilvol_queue_depth (waiting for one).
    void SetLoad(double in_flight, double queued);
    void SetWorkers(int workers, int max_queue);

    /// The text exposition format.
    std::string Serialize() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace soilvol::server
