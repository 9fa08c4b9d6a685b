#pragma once

#include <cstdint>
#include <functional>
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

    /// What the estimate records did since the server started, read at each scrape.
    struct RecordFigures {
        std::uint64_t written = 0, batches = 0, failures = 0, pruned = 0;
        std::size_t queued = 0;   ///< waiting for their commit
        std::size_t watches = 0;  ///< open WatchEstimates calls and SSE streams
    };
    /// soilvol_records_written_total, soilvol_record_batches_total,
    /// soilvol_record_failures_total and soilvol_records_pruned_total (labelled with the
    /// store: "sqlite" or "postgresql"), soilvol_records_queued and soilvol_estimate_watches,
    /// from `probe` at each Serialize. Set once, before the first scrape.
    void SetRecordsProbe(std::string store, std::function<RecordFigures()> probe);

    /// The text exposition format.
    std::string Serialize() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace soilvol::server
