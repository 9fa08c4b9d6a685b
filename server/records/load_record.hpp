#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "absl/status/status.h"

namespace soilvol::server {

/// A truck load as kept (soilvol.v1.Load without its figures, which come from its passes'
/// records): the columns its queries select by, the client's fields as a serialized
/// soilvol.v1.Load payload. States and close reasons are the proto's numbers.
struct LoadRecord {
    static constexpr int kOpen = 1, kClosed = 2;
    static constexpr int kNotClosed = 0, kExplicit = 1, kNewLoad = 2, kIdle = 3;

    std::int64_t seq = 0;  ///< set by the store: increasing in the order loads were created
    std::string load_id;
    std::string haul_unit_id;
    std::string body_container_id;
    int state = kOpen;
    int close_reason = kNotClosed;
    std::int64_t create_time_us = 0;
    std::int64_t update_time_us = 0;
    std::int64_t close_time_us = 0;
    /// The create or the last pass: what the idle time counts from.
    std::int64_t last_activity_us = 0;
    std::int64_t revision = 1;  ///< +1 at every change (the etag)
    std::int64_t passes = 0;    ///< passes that joined it
    std::string request_id;
    std::string payload;
};

/// `load` as it stands at `now_us` when open loads close after `idle_us` without a pass (0:
/// never): an open load idle that long is closed (kIdle, at its last activity plus idle_us).
/// Whether it changed.
bool ApplyIdleClose(LoadRecord& load, std::int64_t now_us, std::int64_t idle_us);

/// Closes `load` at `now_us` for `reason` (kExplicit or kNewLoad) unless it is closed already
/// or ApplyIdleClose closes it first. Whether it changed.
bool CloseLoadAt(LoadRecord& load, int reason, std::int64_t now_us, std::int64_t idle_us);

/// OK when `revision` is unset or the load's; Aborted (reason ETAG_MISMATCH) otherwise.
absl::Status CheckLoadRevision(const LoadRecord& load, std::optional<std::int64_t> revision);

/// What a new estimate record is to its load (EstimateRecord::load).
struct LoadLink {
    static constexpr int kPass = 1, kBodyScan = 2;
    std::string load_id;
    int role = kPass;
    std::int64_t idle_us = 0;  ///< the server's idle close (--load-idle-seconds; 0: never)
};

/// Whether a record linked by `link` joins `load` (already brought to its state at the
/// record's time by ApplyIdleClose): a body scan always, a pass only to an open load;
/// FailedPrecondition naming load_id otherwise.
absl::Status CheckJoin(const LoadRecord& load, const LoadLink& link);

/// What a record that joined its load brings to production.
struct JoinedLoad {
    std::string haul_unit_id;  ///< "" for a record of no load
    bool first_pass = false;
    bool body_scan = false;  ///< its soil was counted in the passes: not production
    LoadRecord load;         ///< the load after the record joined (its event's state)
};

/// `load` after a record linked by `link` at `time_us` joined it (CheckJoin passed): its
/// update time, last activity (a pass), revision and passes moved on; what the record brings.
JoinedLoad JoinLoadRecord(LoadRecord& load, const LoadLink& link, std::int64_t time_us);

/// Which loads a ListLoads returns, newest first.
struct LoadQuery {
    std::string haul_unit_id;  ///< "" for every haul unit
    /// Only loads in this state, idle ones counting as closed from open_since_us (the loads
    /// with a last activity before it).
    std::optional<int> state;
    std::int64_t open_since_us = std::numeric_limits<std::int64_t>::min();
    std::optional<std::int64_t> before_seq;  ///< a page after the previous one
    int limit = 100;
};

}  // namespace soilvol::server
