#include "server/records/load_event_sql.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "server/records/alert_sql.hpp"

namespace soilvol::server {
namespace {

// For BackendSql: "@" stands for the table prefix, @SERIAL and @BLOB for the backend's types.
constexpr const char* kLoadEventSchema = R"sql(
CREATE TABLE IF NOT EXISTS @load_events (
    id @SERIAL,
    kind INTEGER NOT NULL,
    time_us BIGINT NOT NULL,
    container_id TEXT NOT NULL,
    estimate_id BIGINT NOT NULL,
    through_estimate_id BIGINT NOT NULL,
    seq BIGINT NOT NULL,
    load_id TEXT NOT NULL,
    haul_unit_id TEXT NOT NULL,
    body_container_id TEXT NOT NULL,
    state INTEGER NOT NULL,
    close_reason INTEGER NOT NULL,
    create_time_us BIGINT NOT NULL,
    update_time_us BIGINT NOT NULL,
    close_time_us BIGINT NOT NULL,
    last_activity_us BIGINT NOT NULL,
    revision BIGINT NOT NULL,
    request_id TEXT NOT NULL,
    payload @BLOB NOT NULL,
    passes BIGINT NOT NULL);
CREATE INDEX IF NOT EXISTS @load_events_by_container ON @load_events (container_id, id);
CREATE INDEX IF NOT EXISTS @load_events_by_time ON @load_events (time_us);
)sql";

constexpr const char* kEventColumnList =
    "seq, load_id, haul_unit_id, body_container_id, state, close_reason, create_time_us, "
    "update_time_us, close_time_us, last_activity_us, revision, request_id, payload, passes, id, "
    "kind, time_us, container_id, estimate_id, through_estimate_id";

}  // namespace

LoadEventSql::LoadEventSql(const std::string& prefix, bool sqlite) {
    auto sql = [&](const std::string& text) { return BackendSql(text, prefix, sqlite); };
    schema = sql(kLoadEventSchema);
    // The load's newest record, this change's included: committed before its event.
    insert_event = sql(
        "INSERT INTO @load_events (kind, time_us, container_id, estimate_id, seq, load_id, "
        "haul_unit_id, body_container_id, state, close_reason, create_time_us, update_time_us, "
        "close_time_us, last_activity_us, revision, request_id, payload, passes, "
        "through_estimate_id) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, "
        "$14, $15, $16, $17, $18, (SELECT COALESCE(MAX(id), 0) FROM @estimates WHERE load_id = $6 "
        "AND load_id <> '')) RETURNING id");
    prune_events = sql("DELETE FROM @load_events WHERE time_us < $1");
    purge_events = sql("DELETE FROM @load_events WHERE container_id = $1");
    list_after = sql(absl::StrCat(
        "SELECT ", kEventColumnList,
        " FROM @load_events WHERE id > $1 AND ($2 = '' OR container_id = $2) AND ($3 = '' OR "
        "haul_unit_id = $3) ORDER BY id ASC LIMIT $4"));
    list_newest = absl::StrReplaceAll(list_after, {{" ASC ", " DESC "}});
}

}  // namespace soilvol::server
