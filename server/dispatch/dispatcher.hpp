#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "server/auth/authenticator.hpp"
#include "server/dispatch/metrics.hpp"
#include "server/dispatch/worker_pool.hpp"
#include "server/handlers/call_record.hpp"

namespace soilvol::server {

using Clock = std::chrono::steady_clock;

/// What a transport knows about one call.
struct CallContext {
    std::string method;     ///< RPC name: "EstimateVolume"
    std::string transport;  ///< "grpc" or "http"
    std::string peer;
    std::string authorization;  ///< the Authorization header or metadata value, "" without
    std::string tls_identity;   ///< a verified client certificate's subject, "" without
    Clock::time_point received = Clock::now();
    Clock::time_point deadline = Clock::time_point::max();
    std::function<bool()> cancelled;  ///< may be empty; called from any thread
    std::string principal;            ///< who called, set once the call is authorized
    std::string request_id;           ///< RequestIdOf what the caller sent: logged and echoed
    std::string trace_id;             ///< TraceIdOf its traceparent, "" without
};

/// Runs every RPC of both transports on the bounded worker pool, then logs one line (and an
/// audit line for every call that needs the admin scope) and records the metrics for it.
class Dispatcher {
  public:
    using Work = std::function<absl::Status(CallRecord&)>;
    using Done = std::function<void(const absl::Status&)>;

    Dispatcher(WorkerPool& pool, Metrics& metrics, const Authenticator& authenticator);

    /// Whether the caller may make the call (RequiredScope of its method): OK, or
    /// UNAUTHENTICATED / PERMISSION_DENIED; context.principal names the caller when known.
    /// Submit checks it; REST also asks before it reads a body.
    absl::Status Authorize(CallContext& context) const;

    /// Authorizes, then runs `work` on a worker and `done` with its status on that worker.
    /// When the caller may not call, the pool is full or stopping, `done` gets
    /// UNAUTHENTICATED / PERMISSION_DENIED / RESOURCE_EXHAUSTED / UNAVAILABLE at once on this
    /// thread; when the deadline passed or the caller went away while the call waited, `done`
    /// gets DEADLINE_EXCEEDED / CANCELLED and `work` never runs.
    void Submit(CallContext context, Work work, Done done);

    /// From now on every call's stop token has stopped (the shutdown grace is over).
    void StopAll() { stop_all_->store(true); }

    /// Logs and counts a call that failed before reaching the pool (a body that does not
    /// parse, an unknown route).
    void Refuse(const CallContext& context, const absl::Status& status);

  private:
    void Finish(const CallContext& context, const CallRecord& record, const absl::Status& status,
                const Done& done);

    WorkerPool& pool_;
    Metrics& metrics_;
    const Authenticator& authenticator_;
    std::shared_ptr<std::atomic<bool>> stop_all_ = std::make_shared<std::atomic<bool>>(false);
};

}  // namespace soilvol::server
