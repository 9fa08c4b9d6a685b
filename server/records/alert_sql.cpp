#include "server/records/alert_sql.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"

namespace soilvol::server {
namespace {

// "@" stands for the table prefix; types are what both backends take (BIGINT is an INTEGER
// to SQLite; the alert and delivery ids are the backend's own auto-increment, see BackendSql).
constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS @alerts (
    id @SERIAL,
    kind INTEGER NOT NULL,
    create_time_us BIGINT NOT NULL,
    container_id TEXT NOT NULL,
    estimate_id BIGINT NOT NULL,
    load_id TEXT NOT NULL,
    haul_unit_id TEXT NOT NULL,
    request_id TEXT NOT NULL,
    message TEXT NOT NULL,
    value DOUBLE PRECISION NOT NULL,
    threshold DOUBLE PRECISION NOT NULL);
CREATE INDEX IF NOT EXISTS @alerts_by_container ON @alerts (container_id, id);
CREATE INDEX IF NOT EXISTS @alerts_by_time ON @alerts (create_time_us);
CREATE TABLE IF NOT EXISTS @alert_refusals (
    container_id TEXT PRIMARY KEY,
    run BIGINT NOT NULL);
CREATE TABLE IF NOT EXISTS @webhooks (
    webhook_id TEXT PRIMARY KEY,
    cursor_id BIGINT NOT NULL,
    holder TEXT NOT NULL,
    lease_until_us BIGINT NOT NULL,
    last_delivery_us BIGINT NOT NULL,
    failing_attempts INTEGER NOT NULL,
    last_error TEXT NOT NULL,
    next_attempt_us BIGINT NOT NULL);
CREATE TABLE IF NOT EXISTS @webhook_deliveries (
    id @SERIAL,
    webhook_id TEXT NOT NULL,
    alert_id BIGINT NOT NULL,
    attempt INTEGER NOT NULL,
    time_us BIGINT NOT NULL,
    outcome INTEGER NOT NULL,
    http_status INTEGER NOT NULL,
    error TEXT NOT NULL,
    latency_ms DOUBLE PRECISION NOT NULL,
    delay_ms DOUBLE PRECISION NOT NULL);
CREATE INDEX IF NOT EXISTS @webhook_deliveries_by_webhook ON @webhook_deliveries (webhook_id, id);
CREATE INDEX IF NOT EXISTS @webhook_deliveries_by_alert ON @webhook_deliveries (alert_id);
CREATE INDEX IF NOT EXISTS @webhook_deliveries_by_time ON @webhook_deliveries (time_us);
CREATE INDEX IF NOT EXISTS @loads_unjudged ON @loads (seq) WHERE judged = 0;
)sql";

constexpr const char* kAlertColumnList =
    "id, kind, create_time_us, container_id, estimate_id, load_id, haul_unit_id, request_id, "
    "message, value, threshold";

}  // namespace

AlertSql::AlertSql(const std::string& prefix, bool sqlite) : prefix_(prefix), sqlite_(sqlite) {
    schema = Sql(kSchema);
    insert_alert = Sql(
        "INSERT INTO @alerts (kind, create_time_us, container_id, estimate_id, load_id, "
        "haul_unit_id, request_id, message, value, threshold) VALUES ($1, $2, $3, $4, $5, $6, $7, "
        "$8, $9, $10) RETURNING id");
    count_refusal = Sql(
        "INSERT INTO @alert_refusals (container_id, run) VALUES ($1, 1) ON CONFLICT (container_id) "
        "DO UPDATE SET run = @alert_refusals.run + 1 RETURNING run");
    end_refusals = Sql("DELETE FROM @alert_refusals WHERE container_id = $1");
    judge_load = Sql("UPDATE @loads SET judged = 1 WHERE load_id = $1 AND judged = 0");
    unjudged_loads =
        Sql("SELECT load_id FROM @loads WHERE judged = 0 AND (state = 2 OR last_activity_us < $1) "
            "ORDER BY seq LIMIT $2");
    create_webhook = Sql(
        "INSERT INTO @webhooks (webhook_id, cursor_id, holder, lease_until_us, last_delivery_us, "
        "failing_attempts, last_error, next_attempt_us) VALUES ($1, (SELECT COALESCE(MAX(id), 0) "
        "FROM @alerts), '', 0, 0, 0, '', 0) ON CONFLICT (webhook_id) DO NOTHING");
    lease_webhook = Sql(
        "UPDATE @webhooks SET holder = $2, lease_until_us = $4 WHERE webhook_id = $1 AND (holder "
        "= $2 OR lease_until_us < $3) RETURNING cursor_id, last_delivery_us, failing_attempts, "
        "last_error, next_attempt_us");
    save_webhook =
        Sql("UPDATE @webhooks SET cursor_id = $3, last_delivery_us = $4, failing_attempts = $5, "
            "last_error = $6, next_attempt_us = $7 WHERE webhook_id = $1 AND holder = $2");
    release_webhook = Sql(
        "UPDATE @webhooks SET holder = '', lease_until_us = 0 WHERE webhook_id = $1 AND holder = "
        "$2");
    insert_delivery =
        Sql("INSERT INTO @webhook_deliveries (webhook_id, alert_id, attempt, time_us, outcome, "
            "http_status, error, latency_ms, delay_ms) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9) "
            "RETURNING id");
    webhook_state =
        Sql("SELECT cursor_id, last_delivery_us, failing_attempts, last_error, next_attempt_us, "
            "(SELECT COUNT(*) FROM @alerts WHERE id > w.cursor_id) FROM @webhooks AS w WHERE "
            "webhook_id = $1");
    list_deliveries =
        Sql("SELECT id, webhook_id, alert_id, attempt, time_us, outcome, http_status, error, "
            "latency_ms, delay_ms FROM @webhook_deliveries WHERE ($1 = '' OR webhook_id = $1) AND "
            "(CAST($2 AS BIGINT) = 0 OR alert_id = $2) AND id < $3 ORDER BY id DESC LIMIT $4");
    prune_alerts = Sql("DELETE FROM @alerts WHERE create_time_us < $1");
    prune_deliveries = Sql("DELETE FROM @webhook_deliveries WHERE time_us < $1");
    purge_alerts = Sql("DELETE FROM @alerts WHERE container_id = $1");
}

std::string AlertSql::ListAlertsSql(bool ascending) const {
    return Sql(absl::StrCat("SELECT ", kAlertColumnList,
                            " FROM @alerts WHERE id > $1 AND id < $2 AND create_time_us >= $3 AND "
                            "create_time_us < $4 AND ($5 = '' OR container_id = $5) AND ($6 = 0 "
                            "OR kind = $6) ORDER BY id ",
                            ascending ? "ASC" : "DESC", " LIMIT $7")
                   .c_str());
}

std::string AlertSql::Sql(const char* text) const { return BackendSql(text, prefix_, sqlite_); }

std::string BackendSql(const std::string& text, const std::string& prefix, bool sqlite) {
    std::string sql = absl::StrReplaceAll(
        text, {{"@SERIAL", sqlite ? "INTEGER PRIMARY KEY AUTOINCREMENT" : "BIGSERIAL PRIMARY KEY"},
               {"@BLOB", sqlite ? "BLOB" : "BYTEA"}});
    sql = absl::StrReplaceAll(sql, {{"@", prefix}});
    if (sqlite) sql = absl::StrReplaceAll(sql, {{"$", "?"}});
    return sql;
}

}  // namespace soilvol::server
