#pragma once

#include <string>

namespace soilvol::server {

/// The SQL of load events (LoadEventRecord), written once for both backends as AlertSql is:
/// `prefix` names the tables ("" for SQLite, "soilvol_" for PostgreSQL) and `sqlite` turns $N
/// parameters into ?N.
struct LoadEventSql {
    LoadEventSql(const std::string& prefix, bool sqlite);

    std::string schema;        ///< the table and its indexes (IF NOT EXISTS)
    std::string insert_event;  ///< $1 kind .. $4 estimate_id, $5 seq .. $18 passes; RETURNING id
    std::string prune_events;  ///< $1 oldest kept (us)
    std::string purge_events;  ///< $1 container_id
    /// ListLoadEvents: $1 after, $2 container or '', $3 haul unit or '', $4 limit; oldest first
    /// (after an id), or the newest first.
    std::string list_after, list_newest;
};

/// Columns of a listed event: the load's (as the loads table's, seq first: a load reader takes
/// the row as it is), then these.
inline constexpr int kLoadEventIdColumn = 14;  ///< then kind, time_us, container_id,
                                               ///< estimate_id, through_estimate_id

}  // namespace soilvol::server
