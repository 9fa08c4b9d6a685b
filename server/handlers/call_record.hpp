#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "core/common/stop_token.hpp"

namespace soilvol::server {

/// What a handler tells the request log and the metrics about its call.
struct CallRecord {
    double queue_ms = 0.0;  ///< set before the handler runs
    /// Set before the handler runs: stops at the call's deadline, when its caller goes away
    /// and when the server's shutdown grace is over. Nothing is stored once it stopped.
    StopToken stop;
    std::vector<std::pair<std::string, std::string>> ids;  ///< ("container", "bucket-7"), ...
    std::optional<double> volume_m3;
    /// Set by EstimateVolume when it answers (with volume_m3): what the per-container metrics
    /// count.
    struct Measured {
        std::string container_id;
        std::string load_status;  ///< "loaded_ok", "overloaded", ... ("loaded": no targets)
        double bank_volume_m3 = 0.0;
        std::optional<double> mass_kg;  ///< with the material's density
    };
    std::optional<Measured> measured;
    std::vector<std::pair<std::string, double>> stages_ms;  ///< ("align", 10.2), ...
    /// Set by a handler whose answer also waits on something that needs no worker (its
    /// record's commit): once the handler returned OK, the dispatcher calls it with the
    /// call's completion and the worker moves on; the call ends (log line, metrics, answer)
    /// when the completion is called, from any thread, with the final status. The response
    /// stays the handler's to fill until then.
    std::function<void(std::function<void(absl::Status)>)> finish_later;
};

}  // namespace soilvol::server
