#pragma once

#include <string>

namespace soilvol::server {

/// The SQL of alerts, refusal runs and webhooks, written once for both backends: `prefix`
/// names the tables ("" for SQLite, "soilvol_" for PostgreSQL) and `sqlite` turns $N
/// parameters into ?N. Parameters are numbered as each statement's comment says.
struct AlertSql {
    AlertSql(const std::string& prefix, bool sqlite);

    std::string schema;            ///< tables and indexes (IF NOT EXISTS)
    std::string insert_alert;      ///< $1 kind .. $10 threshold; RETURNING id
    std::string count_refusal;     ///< $1 container_id; RETURNING run
    std::string end_refusals;      ///< $1 container_id
    std::string list_alerts;       ///< see ListAlertsSql
    std::string judge_load;        ///< $1 load_id
    std::string unjudged_loads;    ///< $1 idle before (us), $2 limit
    std::string create_webhook;    ///< $1 webhook_id
    std::string lease_webhook;     ///< $1 webhook_id, $2 holder, $3 now, $4 lease until
    std::string save_webhook;      ///< $1 id, $2 holder, $3 cursor .. $7 next attempt
    std::string release_webhook;   ///< $1 webhook_id, $2 holder
    std::string insert_delivery;   ///< $1 webhook_id .. $9 delay_ms; RETURNING id
    std::string webhook_state;     ///< $1 webhook_id
    std::string list_deliveries;   ///< $1 webhook_id or '', $2 alert_id or 0, $3 before, $4 limit
    std::string prune_alerts;      ///< $1 oldest kept (us)
    std::string prune_deliveries;  ///< $1 oldest kept (us)
    std::string purge_alerts;      ///< $1 container_id

    /// ListAlerts: $1 after, $2 before, $3 start, $4 end, $5 container or '', $6 kind or 0,
    /// $7 limit; ascending with an after id.
    std::string ListAlertsSql(bool ascending) const;

  private:
    std::string Sql(const char* text) const;
    std::string prefix_;
    bool sqlite_;
};

/// `text` for one backend: "@" names a table (`prefix` before it), @SERIAL and @BLOB the
/// backend's auto-increment key and byte string, and for SQLite $N parameters become ?N.
std::string BackendSql(const std::string& text, const std::string& prefix, bool sqlite);

/// Columns of a listed alert, in AlertRecord order (id first).
inline constexpr int kAlertColumns = 11;

}  // namespace soilvol::server
