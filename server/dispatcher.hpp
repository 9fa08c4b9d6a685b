#pragma once

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "server/metrics.hpp"
#include "server/worker_pool.hpp"

namespace soilvol::server {

using Clock = std::chrono::steady_clock;

/// What a transport knows about one call.
struct CallContext {
    std::string method;     ///< RPC name: "EstimateVolume"
    std::string transport;  ///< "grpc" or "http"
    std::string peer;
    Clock::time_point received = Clock::now();
    Clock::time_point deadline = Clock::time_point::max();
    std::function<bool()> cancelled;  ///< may be empty
};

/// What a handler tells the request log and the metrics about its call.
struct CallRecord {
    double queue_ms = 0.0;                                 ///< set before the handler runs
    std::vector<std::pair<std::string, std::string>> ids;  ///< ("container", "bucket-7"), ...
    std::optional<double> volume_m3;
    std::vector<std::pair<std::string, double>> stages_ms;  ///< ("align", 10.2), ...
};

/// Runs every RPC of both transports on the bounded worker pool, then logs one line and
/// records the metrics for it.
class Dispatcher {
  public:
    using Work = std::function<absl::Status(CallRecord&)>;
    using Done = std::function<void(const absl::Status&)>;

    Dispatcher(WorkerPool& pool, Metrics& metrics);

    /// Runs `work` on a worker, then `done` with its status on that worker. When the pool is
    /// full or stopping, `done` gets RESOURCE_EXHAUSTED / UNAVAILABLE at once on this thread;
    /// when the deadline passed or the caller went away while the call waited, `done` gets
    /// DEADLINE_EXCEEDED / CANCELLED and `work` never runs.
    void Submit(CallContext context, Work work, Done done);

    /// Logs and counts a call that failed before reaching the pool (a body that does not
    /// parse, an unknown route).
    void Refuse(const CallContext& context, const absl::Status& status);

  private:
    void Finish(const CallContext& context, const CallRecord& record, const absl::Status& status,
                const Done& done);

    WorkerPool& pool_;
    Metrics& metrics_;
};

}  // namespace soilvol::server
