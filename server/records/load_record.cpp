#include "server/records/load_record.hpp"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "server/base/status_map.hpp"

namespace soilvol::server {

bool ApplyIdleClose(LoadRecord& load, std::int64_t now_us, std::int64_t idle_us) {
    if (load.state != LoadRecord::kOpen || idle_us <= 0) return false;
    const std::int64_t idle_at = load.last_activity_us + idle_us;
    if (now_us < idle_at) return false;
    load.state = LoadRecord::kClosed;
    load.close_reason = LoadRecord::kIdle;
    load.close_time_us = idle_at;
    load.update_time_us = idle_at;
    ++load.revision;
    return true;
}

bool CloseLoadAt(LoadRecord& load, int reason, std::int64_t now_us, std::int64_t idle_us) {
    if (ApplyIdleClose(load, now_us, idle_us)) return true;
    if (load.state != LoadRecord::kOpen) return false;
    load.state = LoadRecord::kClosed;
    load.close_reason = reason;
    load.close_time_us = now_us;
    load.update_time_us = now_us;
    ++load.revision;
    return true;
}

absl::Status CheckLoadRevision(const LoadRecord& load, std::optional<std::int64_t> revision) {
    if (!revision || *revision == load.revision) return absl::OkStatus();
    return WithReason(
        absl::AbortedError(absl::StrCat("etag: load '", load.load_id,
                                        "' has changed since that etag was read; read it again")),
        "ETAG_MISMATCH");
}

JoinedLoad JoinLoadRecord(LoadRecord& load, const LoadLink& link, std::int64_t time_us) {
    load.update_time_us = std::max(load.update_time_us, time_us);
    ++load.revision;
    JoinedLoad joined;
    joined.haul_unit_id = load.haul_unit_id;
    joined.body_scan = link.role == LoadLink::kBodyScan;
    if (!joined.body_scan) {
        load.last_activity_us = time_us;
        joined.first_pass = ++load.passes == 1;
    }
    joined.load = load;
    return joined;
}

absl::Status CheckJoin(const LoadRecord& load, const LoadLink& link) {
    if (link.role == LoadLink::kBodyScan || load.state == LoadRecord::kOpen) {
        return absl::OkStatus();
    }
    const char* why = load.close_reason == LoadRecord::kIdle ? "idle too long"
                      : load.close_reason == LoadRecord::kNewLoad
                          ? "its haul unit started a new load"
                          : "closed";
    return absl::FailedPreconditionError(
        absl::StrCat("load_id: load '", load.load_id, "' is closed (", why,
                     ") and takes no more passes; create a new load"));
}

}  // namespace soilvol::server
