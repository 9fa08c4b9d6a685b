#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/status.h"

namespace soilvol::server {

/// Prometheus metrics of one server (prometheus-cpp, pull model: the REST gateway serves
/// Serialize() on /metrics). Thread-safe.
class Metrics {
  public:
    /// `max_containers`: how many containers get their own label on the per-container
    /// figures; the rest are summed under container="_other" (a bounded label set).
    explicit Metrics(int max_containers = 200);
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

    /// An answered estimate: soilvol_estimates_total{container, load_status},
    /// soilvol_estimated_volume_cubic_meters_total{container} (loose) and
    /// soilvol_estimated_bank_volume_cubic_meters_total{container}, and
    /// soilvol_estimated_mass_kilograms_total{container} when the density is known.
    void RecordEstimate(std::string_view container, std::string_view load_status, double volume_m3,
                        double bank_volume_m3, std::optional<double> mass_kg);

    /// What the estimate records did since the server started, read at each scrape.
    struct RecordFigures {
        std::uint64_t written = 0, batches = 0, failures = 0, pruned = 0;
        std::size_t queued = 0;  ///< waiting for their commit
        /// open watches (gRPC calls and SSE streams) of estimates, alerts and loads
        std::size_t estimate_watches = 0, alert_watches = 0, load_watches = 0;
    };
    /// soilvol_records_written_total, soilvol_record_batches_total,
    /// soilvol_record_failures_total and soilvol_records_pruned_total (labelled with the
    /// store: "sqlite" or "postgresql"), soilvol_records_queued and soilvol_watches{feed},
    /// from `probe` at each Serialize. Set once, before the first scrape.
    void SetRecordsProbe(std::string store, std::function<RecordFigures()> probe);

    /// One value of a probed counter family, with its labels.
    struct ProbedValue {
        std::vector<std::pair<std::string, std::string>> labels;
        double value = 0.0;
    };
    /// A counter family whose values another part of the server keeps (they only grow), read
    /// from `probe` at each Serialize. Set before the first scrape.
    void AddCounterProbe(std::string name, std::string help,
                         std::function<std::vector<ProbedValue>()> probe);

    /// The text exposition format, with the process_* figures of this process (CPU seconds,
    /// resident and virtual memory, open and most file descriptors, start time) read now.
    std::string Serialize() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace soilvol::server
