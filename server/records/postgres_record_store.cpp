#include <algorithm>
#include <memory>
#include <mutex>
#include <optional>
#include <pqxx/pqxx>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/status_macros.hpp"
#include "server/records/alert_sql.hpp"
#include "server/records/load_event_sql.hpp"
#include "server/records/record_store.hpp"

namespace soilvol::server {
namespace {

constexpr const char* kPostgresSchema = R"sql(
CREATE TABLE IF NOT EXISTS soilvol_estimates (
    id BIGSERIAL PRIMARY KEY,
    container_id TEXT NOT NULL,
    create_time_us BIGINT NOT NULL,
    request_id TEXT NOT NULL,
    payload BYTEA NOT NULL);
CREATE INDEX IF NOT EXISTS soilvol_estimates_by_container
    ON soilvol_estimates (container_id, id);
CREATE INDEX IF NOT EXISTS soilvol_estimates_by_time ON soilvol_estimates (create_time_us);
ALTER TABLE soilvol_estimates ADD COLUMN IF NOT EXISTS registration_id TEXT NOT NULL DEFAULT '';
CREATE INDEX IF NOT EXISTS soilvol_estimates_by_registration
    ON soilvol_estimates (container_id, registration_id, id);
ALTER TABLE soilvol_estimates ADD COLUMN IF NOT EXISTS load_id TEXT NOT NULL DEFAULT '';
ALTER TABLE soilvol_estimates ADD COLUMN IF NOT EXISTS load_role INTEGER NOT NULL DEFAULT 0;
CREATE INDEX IF NOT EXISTS soilvol_estimates_by_load
    ON soilvol_estimates (load_id, id) WHERE load_id <> '';
CREATE TABLE IF NOT EXISTS soilvol_loads (
    seq BIGSERIAL PRIMARY KEY,
    load_id TEXT NOT NULL UNIQUE,
    haul_unit_id TEXT NOT NULL,
    body_container_id TEXT NOT NULL,
    state INTEGER NOT NULL,
    close_reason INTEGER NOT NULL,
    create_time_us BIGINT NOT NULL,
    update_time_us BIGINT NOT NULL,
    close_time_us BIGINT NOT NULL,
    last_activity_us BIGINT NOT NULL,
    revision BIGINT NOT NULL,
    passes BIGINT NOT NULL,
    request_id TEXT NOT NULL,
    payload BYTEA NOT NULL);
CREATE TABLE IF NOT EXISTS soilvol_production (
    bucket_us BIGINT NOT NULL,
    container_id TEXT NOT NULL,
    haul_unit_id TEXT NOT NULL,
    material TEXT NOT NULL,
    passes BIGINT NOT NULL,
    loads BIGINT NOT NULL,
    volume_m3 DOUBLE PRECISION NOT NULL,
    bank_volume_m3 DOUBLE PRECISION NOT NULL,
    mass_kg DOUBLE PRECISION NOT NULL,
    mass_passes BIGINT NOT NULL,
    fill_ratio_sum DOUBLE PRECISION NOT NULL,
    status_0 BIGINT NOT NULL, status_1 BIGINT NOT NULL, status_2 BIGINT NOT NULL,
    status_3 BIGINT NOT NULL, status_4 BIGINT NOT NULL, status_5 BIGINT NOT NULL,
    status_6 BIGINT NOT NULL,
    PRIMARY KEY (bucket_us, container_id, haul_unit_id, material));
CREATE TABLE IF NOT EXISTS soilvol_production_rollup (
    granularity_us BIGINT NOT NULL,
    dimension INTEGER NOT NULL,
    bucket_us BIGINT NOT NULL,
    key TEXT NOT NULL,
    passes BIGINT NOT NULL,
    loads BIGINT NOT NULL,
    volume_m3 DOUBLE PRECISION NOT NULL,
    bank_volume_m3 DOUBLE PRECISION NOT NULL,
    mass_kg DOUBLE PRECISION NOT NULL,
    mass_passes BIGINT NOT NULL,
    fill_ratio_sum DOUBLE PRECISION NOT NULL,
    status_0 BIGINT NOT NULL, status_1 BIGINT NOT NULL, status_2 BIGINT NOT NULL,
    status_3 BIGINT NOT NULL, status_4 BIGINT NOT NULL, status_5 BIGINT NOT NULL,
    status_6 BIGINT NOT NULL,
    PRIMARY KEY (granularity_us, dimension, bucket_us, key));
ALTER TABLE soilvol_loads ADD COLUMN IF NOT EXISTS passes BIGINT NOT NULL DEFAULT 0;
CREATE UNIQUE INDEX IF NOT EXISTS soilvol_loads_open_by_haul_unit
    ON soilvol_loads (haul_unit_id) WHERE state = 1;
CREATE INDEX IF NOT EXISTS soilvol_loads_by_haul_unit ON soilvol_loads (haul_unit_id, seq);
-- Loads from before alerts count as judged; CreateLoad writes 0.
ALTER TABLE soilvol_loads ADD COLUMN IF NOT EXISTS judged INTEGER NOT NULL DEFAULT 1;
)sql";

constexpr const char* kPgLoadColumns =
    "seq, load_id, haul_unit_id, body_container_id, state, close_reason, create_time_us, "
    "update_time_us, close_time_us, last_activity_us, revision, request_id, payload, passes";

constexpr const char* kRecordColumns =
    "id, container_id, create_time_us, request_id, registration_id, load_id, load_role";

/// Taken by every inserting transaction: ids are drawn and committed one transaction at a
/// time, so that across replicas a record committed later always has a larger id (a watcher
/// that resumes after the last id it saw misses none).
constexpr std::int64_t kInsertLock = 0x50156f6c;  // "soil"

absl::Status PgError(const std::exception& e, const char* what) {
    std::string message = absl::StrCat("records (postgresql): ", what, ": ", e.what());
    while (!message.empty() && message.back() == '\n') message.pop_back();
    if (dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr ||
        dynamic_cast<const pqxx::in_doubt_error*>(&e) != nullptr) {
        return absl::UnavailableError(message);
    }
    return absl::InternalError(message);
}

EstimateRecord RecordFrom(const pqxx::row& row, bool with_payload) {
    EstimateRecord record;
    record.id = row[0].as<std::int64_t>();
    record.container_id = row[1].as<std::string>();
    record.create_time_us = row[2].as<std::int64_t>();
    record.request_id = row[3].as<std::string>();
    record.registration_id = row[4].as<std::string>();
    if (const std::string load_id = row[5].as<std::string>(); !load_id.empty()) {
        record.load = LoadLink{load_id, row[6].as<int>(), 0};
    }
    if (with_payload) record.payload = pqxx::binarystring(row[7]).str();
    return record;
}

LoadRecord PgLoadFrom(const pqxx::row& row) {
    LoadRecord load;
    load.seq = row[0].as<std::int64_t>();
    load.load_id = row[1].as<std::string>();
    load.haul_unit_id = row[2].as<std::string>();
    load.body_container_id = row[3].as<std::string>();
    load.state = row[4].as<int>();
    load.close_reason = row[5].as<int>();
    load.create_time_us = row[6].as<std::int64_t>();
    load.update_time_us = row[7].as<std::int64_t>();
    load.close_time_us = row[8].as<std::int64_t>();
    load.last_activity_us = row[9].as<std::int64_t>();
    load.revision = row[10].as<std::int64_t>();
    load.request_id = row[11].as<std::string>();
    load.payload = pqxx::binarystring(row[12]).str();
    load.passes = row[13].as<std::int64_t>();
    return load;
}

/// A rollup row (RollupSelectSql) of `dimension`.
ProductionCell PgCellFrom(const pqxx::row& row, int dimension) {
    ProductionCell cell;
    cell.bucket_us = row[0].as<std::int64_t>();
    SetCellKey(dimension, row[1].as<std::string>(), cell);
    cell.passes = row[2].as<std::int64_t>();
    cell.loads = row[3].as<std::int64_t>();
    cell.volume_m3 = row[4].as<double>();
    cell.bank_volume_m3 = row[5].as<double>();
    cell.mass_kg = row[6].as<double>();
    cell.mass_passes = row[7].as<std::int64_t>();
    cell.fill_ratio_sum = row[8].as<double>();
    for (int i = 0; i < ProductionCell::kStatuses; ++i) {
        cell.statuses[i] = row[9 + i].as<std::int64_t>();
    }
    return cell;
}

/// A cell's 14 values as parameters, after its 4 keys.
void AppendValues(const ProductionCell& c, std::vector<std::string>& params) {
    const auto number = [](double v) { return absl::StrFormat("%.17g", v); };
    for (const std::int64_t n : {c.passes, c.loads}) params.push_back(std::to_string(n));
    for (const double v : {c.volume_m3, c.bank_volume_m3, c.mass_kg}) params.push_back(number(v));
    params.push_back(std::to_string(c.mass_passes));
    params.push_back(number(c.fill_ratio_sum));
    for (const std::int64_t n : c.statuses) params.push_back(std::to_string(n));
}

/// The batch's production in two statements (each of up to 1000 rows: the fine cells, then
/// the rollup's), not one round trip per record and rollup row: the commit an answer waits for
/// is in series with every estimate.
void PgAddProduction(pqxx::work& work, const std::vector<ProductionCell>& cells) {
    if (cells.empty()) return;
    const ProductionBatch batch = SumBatch(cells);
    constexpr std::size_t kRows = 1000;
    for (std::size_t first = 0; first < batch.fine.size(); first += kRows) {
        const std::size_t n = std::min(kRows, batch.fine.size() - first);
        std::vector<std::string> params;
        for (std::size_t i = first; i < first + n; ++i) {
            const ProductionCell& c = batch.fine[i];
            params.insert(params.end(), {std::to_string(c.bucket_us), c.container_id,
                                         c.haul_unit_id, c.material});
            AppendValues(c, params);
        }
        work.exec_params(ProductionUpsertSql("soilvol_production", '$', static_cast<int>(n)),
                         pqxx::prepare::make_dynamic_params(params));
    }
    for (std::size_t first = 0; first < batch.rollup.size(); first += kRows) {
        const std::size_t n = std::min(kRows, batch.rollup.size() - first);
        std::vector<std::string> params;
        for (std::size_t i = first; i < first + n; ++i) {
            const auto& [key, c] = batch.rollup[i];
            params.insert(params.end(),
                          {std::to_string(key.granularity_us), std::to_string(key.dimension),
                           std::to_string(key.bucket_us), key.key});
            AppendValues(c, params);
        }
        work.exec_params(RollupUpsertSql("soilvol_production_rollup", '$', static_cast<int>(n)),
                         pqxx::prepare::make_dynamic_params(params));
    }
}

void PgRebuildRollup(pqxx::work& work) {
    for (const std::string& sql :
         RollupRebuildSql("soilvol_production", "soilvol_production_rollup")) {
        work.exec(sql);
    }
}

/// The load `load_id`, locked for this transaction's changes; none when there is no such load.
std::optional<LoadRecord> PgReadLoad(pqxx::work& work, const std::string& load_id) {
    const pqxx::result rows =
        work.exec_params(absl::StrCat("SELECT ", kPgLoadColumns,
                                      " FROM soilvol_loads WHERE load_id = $1 FOR UPDATE"),
                         load_id);
    if (rows.empty()) return std::nullopt;
    return PgLoadFrom(rows[0]);
}

void PgWriteLoadState(pqxx::work& work, const LoadRecord& load) {
    work.exec_params(
        "UPDATE soilvol_loads SET state = $2, close_reason = $3, update_time_us = $4, "
        "close_time_us = $5, last_activity_us = $6, revision = $7, passes = $8 WHERE load_id = $1",
        load.load_id, load.state, load.close_reason, load.update_time_us, load.close_time_us,
        load.last_activity_us, load.revision, load.passes);
}

/// The records of `load_id` up to the id `upto`, oldest first, appended to `out`.
void PgReadLoadRecords(pqxx::work& work, const std::string& load_id, std::int64_t upto,
                       std::vector<EstimateRecord>& out) {
    const pqxx::result rows = work.exec_params(
        absl::StrCat("SELECT ", kRecordColumns,
                     ", payload FROM soilvol_estimates WHERE load_id = $1 AND load_id <> '' AND "
                     "id <= $2 ORDER BY id"),
        load_id, upto);
    for (const pqxx::row& row : rows) out.push_back(RecordFrom(row, true));
}

/// Keeps `event` (sets its id).
void PgInsertLoadEvent(pqxx::work& work, const LoadEventSql& sql, LoadEventRecord& event) {
    const LoadRecord& load = event.load;
    const pqxx::binarystring payload(load.payload.data(), load.payload.size());
    event.id =
        work.exec_params(sql.insert_event, event.kind, event.time_us, event.container_id,
                         event.estimate_id, load.seq, load.load_id, load.haul_unit_id,
                         load.body_container_id, load.state, load.close_reason, load.create_time_us,
                         load.update_time_us, load.close_time_us, load.last_activity_us,
                         load.revision, load.request_id, payload, load.passes)[0][0]
            .as<std::int64_t>();
}

/// The event of a load just closed.
void PgKeepClosed(pqxx::work& work, const LoadEventSql& sql, const LoadRecord& load) {
    LoadEventRecord event = LoadEventOf(load, LoadEventRecord::kClosed, load.close_time_us);
    PgInsertLoadEvent(work, sql, event);
}

/// Whether `record` may join its load (see RecordStore::Append), the load's state written
/// when it changes (an idle close's event kept); sets `joined`.
absl::Status PgJoinLoad(pqxx::work& work, const LoadEventSql& sql, const EstimateRecord& record,
                        JoinedLoad* joined) {
    const LoadLink& link = *record.load;
    std::optional<LoadRecord> load = PgReadLoad(work, link.load_id);
    if (!load)
        return absl::NotFoundError(absl::StrCat("load_id: load '", link.load_id, "' not found"));
    const bool idled = ApplyIdleClose(*load, record.create_time_us, link.idle_us);
    if (idled) PgKeepClosed(work, sql, *load);
    absl::Status join = CheckJoin(*load, link);
    if (join.ok()) *joined = JoinLoadRecord(*load, link, record.create_time_us);
    if (join.ok() || idled) PgWriteLoadState(work, *load);
    return join;
}

AlertRecord PgAlertFrom(const pqxx::row& row) {
    AlertRecord alert;
    alert.id = row[0].as<std::int64_t>();
    alert.kind = row[1].as<int>();
    alert.create_time_us = row[2].as<std::int64_t>();
    alert.container_id = row[3].as<std::string>();
    alert.estimate_id = row[4].as<std::int64_t>();
    alert.load_id = row[5].as<std::string>();
    alert.haul_unit_id = row[6].as<std::string>();
    alert.request_id = row[7].as<std::string>();
    alert.message = row[8].as<std::string>();
    alert.value = row[9].as<double>();
    alert.threshold = row[10].as<double>();
    return alert;
}

/// (cursor_id, last_delivery_us, failing_attempts, last_error, next_attempt_us)
WebhookState PgWebhookFrom(const std::string& webhook_id, const pqxx::row& row) {
    WebhookState state;
    state.webhook_id = webhook_id;
    state.cursor = row[0].as<std::int64_t>();
    state.last_delivery_us = row[1].as<std::int64_t>();
    state.failing_attempts = row[2].as<int>();
    state.last_error = row[3].as<std::string>();
    state.next_attempt_us = row[4].as<std::int64_t>();
    return state;
}

DeliveryRecord PgDeliveryFrom(const pqxx::row& row) {
    DeliveryRecord delivery;
    delivery.id = row[0].as<std::int64_t>();
    delivery.webhook_id = row[1].as<std::string>();
    delivery.alert_id = row[2].as<std::int64_t>();
    delivery.attempt = row[3].as<int>();
    delivery.time_us = row[4].as<std::int64_t>();
    delivery.outcome = row[5].as<int>();
    delivery.http_status = row[6].as<int>();
    delivery.error = row[7].as<std::string>();
    delivery.latency_ms = row[8].as<double>();
    delivery.delay_ms = row[9].as<double>();
    return delivery;
}

void PgInsertAlert(pqxx::work& work, const AlertSql& sql, AlertRecord& alert) {
    alert.id =
        work.exec_params(sql.insert_alert, alert.kind, alert.create_time_us, alert.container_id,
                         alert.estimate_id, alert.load_id, alert.haul_unit_id, alert.request_id,
                         alert.message, alert.value, alert.threshold)[0][0]
            .as<std::int64_t>();
}

/// A refused scan (see EstimateRecord::refusal): its container's run grows, and at
/// alert_after its alert is kept.
void PgCountRefusal(pqxx::work& work, const AlertSql& sql, EstimateRecord& record) {
    record.id = 0;
    const std::int64_t run =
        work.exec_params(sql.count_refusal, record.container_id)[0][0].as<std::int64_t>();
    if (run != record.refusal->alert_after) return;
    PgInsertAlert(work, sql, record.refusal->alert);
}

/// A refusal from inside a transaction (the transaction rolls back, the status is returned).
struct Refused {
    absl::Status status;
};

class PostgresRecordStore final : public RecordStore {
  public:
    explicit PostgresRecordStore(std::string url) : url_(std::move(url)) {}

    absl::Status Init() {
        return Run("create the schema", [this](pqxx::work& work) {
            work.exec(kPostgresSchema);
            work.exec(sql_.schema);
            work.exec(events_sql_.schema);
            // A database made before the rollup: made from the fine table once.
            const pqxx::result missing = work.exec(
                "SELECT EXISTS (SELECT 1 FROM soilvol_production) AND NOT EXISTS (SELECT 1 FROM "
                "soilvol_production_rollup)");
            if (missing[0][0].as<bool>()) {
                work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
                PgRebuildRollup(work);
            }
        });
    }

    absl::Status Append(std::vector<EstimateRecord>& records) override {
        absl::Status status = Run("append", [&records, &sql = sql_,
                                             &events = events_sql_](pqxx::work& work) {
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            std::vector<ProductionCell> production;
            for (EstimateRecord& record : records) {
                record.id = 0;
                if (record.refusal) {
                    PgCountRefusal(work, sql, record);
                    continue;
                }
                JoinedLoad joined;
                if (record.load) {
                    record.rejected = PgJoinLoad(work, events, record, &joined);
                    if (!record.rejected.ok()) continue;
                }
                const pqxx::binarystring payload(record.payload.data(), record.payload.size());
                // A kept record ends its container's run of refusals, in the same round trip.
                const pqxx::result id = work.exec_params(
                    "WITH ended AS (DELETE FROM soilvol_alert_refusals WHERE container_id = $1) "
                    "INSERT INTO soilvol_estimates (container_id, create_time_us, request_id, "
                    "payload, registration_id, load_id, load_role) VALUES ($1, $2, $3, $4, $5, "
                    "$6, $7) RETURNING id",
                    record.container_id, record.create_time_us, record.request_id, payload,
                    record.registration_id, record.load ? record.load->load_id : std::string(),
                    record.load ? record.load->role : 0);
                record.id = id[0][0].as<std::int64_t>();
                for (AlertRecord& alert : record.alerts) {
                    alert.estimate_id = record.id;
                    PgInsertAlert(work, sql, alert);
                }
                if (record.load) {
                    LoadEventRecord event =
                        LoadEventOf(joined.load,
                                    joined.body_scan ? LoadEventRecord::kBodyScanned
                                                     : LoadEventRecord::kPassAdded,
                                    record.create_time_us, record.container_id);
                    event.estimate_id = record.id;
                    PgInsertLoadEvent(work, events, event);
                }
                if (!joined.body_scan) {
                    production.push_back(CellOf(record.measures, record.container_id,
                                                joined.haul_unit_id, record.create_time_us,
                                                joined.first_pass));
                }
            }
            PgAddProduction(work, production);
        });
        if (!status.ok()) {
            for (EstimateRecord& record : records) record.id = 0;
        }
        return status;
    }

    absl::StatusOr<EstimateRecord> Get(const std::string& container_id, std::int64_t id) override {
        std::optional<EstimateRecord> found;
        SOILVOL_RETURN_IF_ERROR(Run("get", [&](pqxx::work& work) {
            const pqxx::result rows =
                work.exec_params(absl::StrCat("SELECT ", kRecordColumns,
                                              ", payload FROM soilvol_estimates WHERE "
                                              "id = $1 AND container_id = $2"),
                                 id, container_id);
            if (!rows.empty()) found = RecordFrom(rows[0], true);
        }));
        if (!found) {
            return absl::NotFoundError(
                absl::StrCat("estimate ", id, " of container '", container_id, "' not found"));
        }
        return *std::move(found);
    }

    absl::StatusOr<std::vector<EstimateRecord>> List(const RecordQuery& query) override {
        const bool ascending = query.after_id.has_value();
        const std::string sql = absl::StrCat(
            "SELECT ", kRecordColumns, query.with_payload ? ", payload" : "",
            " FROM soilvol_estimates WHERE id > $1 AND id < $2 AND create_time_us >= $3 AND "
            "create_time_us < $4 AND ($5 = '' OR container_id = $5) AND ($7 = '' OR "
            "registration_id = $7) ORDER BY id ",
            ascending ? "ASC" : "DESC", " LIMIT $6");
        std::vector<EstimateRecord> out;
        SOILVOL_RETURN_IF_ERROR(Run("list", [&](pqxx::work& work) {
            const pqxx::result rows =
                work.exec_params(sql, query.after_id.value_or(0),
                                 query.before_id.value_or(std::numeric_limits<std::int64_t>::max()),
                                 query.start_time_us, query.end_time_us, query.container_id,
                                 static_cast<std::int64_t>(query.limit), query.registration_id);
            for (const pqxx::row& row : rows) out.push_back(RecordFrom(row, query.with_payload));
        }));
        return out;
    }

    absl::StatusOr<std::int64_t> Prune(
        const RetentionPolicy& policy, std::int64_t now_us,
        const std::optional<std::vector<std::string>>& containers) override {
        std::int64_t deleted = 0;
        SOILVOL_RETURN_IF_ERROR(Run("prune", [&](pqxx::work& work) {
            const std::int64_t oldest =
                now_us -
                std::chrono::duration_cast<std::chrono::microseconds>(policy.max_age).count();
            deleted +=
                work.exec_params("DELETE FROM soilvol_estimates WHERE create_time_us < $1", oldest)
                    .affected_rows();
            work.exec_params("DELETE FROM soilvol_loads WHERE update_time_us < $1 AND state = 2",
                             oldest);
            work.exec_params(sql_.prune_alerts, oldest);
            work.exec_params(sql_.prune_deliveries, oldest);
            work.exec_params(events_sql_.prune_events, oldest);
            if (!containers) {
                deleted += work.exec_params(
                                   "DELETE FROM soilvol_estimates WHERE id IN (SELECT id FROM "
                                   "(SELECT id, ROW_NUMBER() OVER (PARTITION BY container_id "
                                   "ORDER BY id DESC) AS n FROM soilvol_estimates) AS ranked "
                                   "WHERE n > $1)",
                                   policy.max_per_container)
                               .affected_rows();
                return;
            }
            for (const std::string& container_id : *containers) {
                // Older than the container's (max+1)-th newest; nothing when it has no more.
                deleted += work.exec_params(
                                   "DELETE FROM soilvol_estimates WHERE container_id = $1 AND "
                                   "id <= (SELECT id FROM soilvol_estimates WHERE container_id "
                                   "= $1 ORDER BY id DESC LIMIT 1 OFFSET $2)",
                                   container_id, policy.max_per_container)
                               .affected_rows();
            }
        }));
        return deleted;
    }

    absl::StatusOr<std::int64_t> DeleteContainer(const std::string& container_id) override {
        std::int64_t deleted = 0;
        SOILVOL_RETURN_IF_ERROR(Run("delete a container's records", [&](pqxx::work& work) {
            deleted = work.exec_params("DELETE FROM soilvol_estimates WHERE container_id = $1",
                                       container_id)
                          .affected_rows();
            work.exec_params(sql_.purge_alerts, container_id);
            work.exec_params(events_sql_.purge_events, container_id);
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            work.exec_params("DELETE FROM soilvol_production WHERE container_id = $1",
                             container_id);
            PgRebuildRollup(work);
        }));
        return deleted;
    }

    absl::Status CreateLoad(LoadRecord& load, std::int64_t idle_us) override {
        return Run("create a load", [&](pqxx::work& work) {
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            if (PgReadLoad(work, load.load_id)) {
                throw Refused{absl::AlreadyExistsError(
                    absl::StrCat("load_id: load '", load.load_id, "' already exists"))};
            }
            const pqxx::result open = work.exec_params(
                absl::StrCat(
                    "SELECT ", kPgLoadColumns,
                    " FROM soilvol_loads WHERE haul_unit_id = $1 AND state = 1 FOR UPDATE"),
                load.haul_unit_id);
            if (!open.empty()) {
                LoadRecord previous = PgLoadFrom(open[0]);
                CloseLoadAt(previous, LoadRecord::kNewLoad, load.create_time_us, idle_us);
                PgWriteLoadState(work, previous);
                PgKeepClosed(work, events_sql_, previous);
            }
            const pqxx::binarystring payload(load.payload.data(), load.payload.size());
            const pqxx::result seq = work.exec_params(
                "INSERT INTO soilvol_loads (load_id, haul_unit_id, body_container_id, state, "
                "close_reason, create_time_us, update_time_us, close_time_us, last_activity_us, "
                "revision, request_id, payload, passes, judged) VALUES ($1, $2, $3, $4, $5, $6, "
                "$7, $8, $9, $10, $11, $12, 0, 0) RETURNING seq",
                load.load_id, load.haul_unit_id, load.body_container_id, load.state,
                load.close_reason, load.create_time_us, load.update_time_us, load.close_time_us,
                load.last_activity_us, load.revision, load.request_id, payload);
            load.seq = seq[0][0].as<std::int64_t>();
            LoadEventRecord created =
                LoadEventOf(load, LoadEventRecord::kCreated, load.create_time_us);
            PgInsertLoadEvent(work, events_sql_, created);
        });
    }

    absl::StatusOr<LoadRecord> GetLoad(const std::string& load_id) override {
        std::optional<LoadRecord> found;
        SOILVOL_RETURN_IF_ERROR(Run("read a load", [&](pqxx::work& work) {
            const pqxx::result rows = work.exec_params(
                absl::StrCat("SELECT ", kPgLoadColumns, " FROM soilvol_loads WHERE load_id = $1"),
                load_id);
            if (!rows.empty()) found = PgLoadFrom(rows[0]);
        }));
        if (!found) return absl::NotFoundError(absl::StrCat("load '", load_id, "' not found"));
        return *std::move(found);
    }

    absl::StatusOr<std::vector<LoadRecord>> ListLoads(const LoadQuery& query) override {
        const std::string state_filter =
            query.state == LoadRecord::kOpen     ? " AND state = 1 AND last_activity_us >= $3"
            : query.state == LoadRecord::kClosed ? " AND (state = 2 OR last_activity_us < $3)"
                                                 : " AND $3::BIGINT IS NOT NULL";
        const std::string sql =
            absl::StrCat("SELECT ", kPgLoadColumns,
                         " FROM soilvol_loads WHERE seq < $1 AND ($2 = '' OR haul_unit_id = $2)",
                         state_filter, " ORDER BY seq DESC LIMIT $4");
        std::vector<LoadRecord> out;
        SOILVOL_RETURN_IF_ERROR(Run("list loads", [&](pqxx::work& work) {
            const pqxx::result rows = work.exec_params(
                sql, query.before_seq.value_or(std::numeric_limits<std::int64_t>::max()),
                query.haul_unit_id, query.open_since_us, static_cast<std::int64_t>(query.limit));
            for (const pqxx::row& row : rows) out.push_back(PgLoadFrom(row));
        }));
        return out;
    }

    absl::StatusOr<LoadRecord> CloseLoad(const std::string& load_id, std::int64_t now_us,
                                         std::int64_t idle_us,
                                         std::optional<std::int64_t> revision) override {
        LoadRecord closed;
        SOILVOL_RETURN_IF_ERROR(Run("close a load", [&](pqxx::work& work) {
            // Its event's id in commit order, as every insert's (and before the row lock, as
            // Append takes them).
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            std::optional<LoadRecord> load = PgReadLoad(work, load_id);
            if (!load) {
                throw Refused{absl::NotFoundError(absl::StrCat("load '", load_id, "' not found"))};
            }
            if (absl::Status current = CheckLoadRevision(*load, revision); !current.ok()) {
                throw Refused{current};
            }
            if (CloseLoadAt(*load, LoadRecord::kExplicit, now_us, idle_us)) {
                PgWriteLoadState(work, *load);
                PgKeepClosed(work, events_sql_, *load);
            }
            closed = *std::move(load);
        }));
        return closed;
    }

    absl::StatusOr<std::vector<ProductionCell>> ProductionCells(
        std::int64_t start_us, std::int64_t end_us, int dimension,
        std::int64_t granularity_us) override {
        std::vector<ProductionCell> out;
        SOILVOL_RETURN_IF_ERROR(Run("read production", [&](pqxx::work& work) {
            const pqxx::result rows =
                work.exec_params(RollupSelectSql("soilvol_production_rollup", '$'), granularity_us,
                                 dimension, start_us, end_us);
            out.reserve(rows.size());
            for (const pqxx::row& row : rows) out.push_back(PgCellFrom(row, dimension));
        }));
        return out;
    }

    absl::StatusOr<std::vector<EstimateRecord>> LoadEstimates(
        const std::vector<std::string>& load_ids) override {
        std::vector<EstimateRecord> out;
        if (load_ids.empty()) return out;
        SOILVOL_RETURN_IF_ERROR(Run("read a load's records", [&](pqxx::work& work) {
            for (const std::string& load_id : load_ids) {
                PgReadLoadRecords(work, load_id, std::numeric_limits<std::int64_t>::max(), out);
            }
        }));
        return out;
    }

    absl::StatusOr<std::vector<LoadEventRecord>> ListLoadEvents(
        const LoadEventQuery& query) override {
        std::vector<LoadEventRecord> out;
        SOILVOL_RETURN_IF_ERROR(Run("list load events", [&](pqxx::work& work) {
            const pqxx::result rows =
                work.exec_params(query.after_id ? events_sql_.list_after : events_sql_.list_newest,
                                 query.after_id.value_or(0), query.container_id, query.haul_unit_id,
                                 static_cast<std::int64_t>(query.limit));
            for (const pqxx::row& row : rows) {
                LoadEventRecord& event = out.emplace_back();
                event.load = PgLoadFrom(row);
                event.id = row[kLoadEventIdColumn].as<std::int64_t>();
                event.kind = row[kLoadEventIdColumn + 1].as<int>();
                event.time_us = row[kLoadEventIdColumn + 2].as<std::int64_t>();
                event.container_id = row[kLoadEventIdColumn + 3].as<std::string>();
                event.estimate_id = row[kLoadEventIdColumn + 4].as<std::int64_t>();
                event.through_estimate_id = row[kLoadEventIdColumn + 5].as<std::int64_t>();
            }
            for (LoadEventRecord& event : out) {
                if (!query.with_records || event.through_estimate_id == 0) continue;
                PgReadLoadRecords(work, event.load.load_id, event.through_estimate_id,
                                  event.records);
            }
        }));
        return out;
    }

    absl::StatusOr<std::vector<AlertRecord>> ListAlerts(const AlertQuery& query) override {
        std::vector<AlertRecord> out;
        SOILVOL_RETURN_IF_ERROR(Run("list alerts", [&](pqxx::work& work) {
            const pqxx::result rows = work.exec_params(
                sql_.ListAlertsSql(query.after_id.has_value()), query.after_id.value_or(0),
                query.before_id.value_or(std::numeric_limits<std::int64_t>::max()),
                query.start_time_us, query.end_time_us, query.container_id, query.kind,
                static_cast<std::int64_t>(query.limit));
            for (const pqxx::row& row : rows) out.push_back(PgAlertFrom(row));
        }));
        return out;
    }

    absl::StatusOr<std::vector<std::string>> UnjudgedLoads(std::int64_t idle_before_us,
                                                           int limit) override {
        std::vector<std::string> out;
        SOILVOL_RETURN_IF_ERROR(Run("find loads to judge", [&](pqxx::work& work) {
            const pqxx::result rows = work.exec_params(sql_.unjudged_loads, idle_before_us,
                                                       static_cast<std::int64_t>(limit));
            for (const pqxx::row& row : rows) out.push_back(row[0].as<std::string>());
        }));
        return out;
    }

    absl::StatusOr<bool> JudgeLoad(const std::string& load_id,
                                   std::optional<AlertRecord>& alert) override {
        bool judged = false;
        SOILVOL_RETURN_IF_ERROR(Run("judge a load", [&](pqxx::work& work) {
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            judged = work.exec_params(sql_.judge_load, load_id).affected_rows() == 1;
            if (judged && alert) PgInsertAlert(work, sql_, *alert);
        }));
        return judged;
    }

    absl::StatusOr<std::optional<WebhookState>> LeaseWebhook(const std::string& webhook_id,
                                                             const std::string& holder,
                                                             std::int64_t now_us,
                                                             std::int64_t lease_until_us) override {
        std::optional<WebhookState> state;
        SOILVOL_RETURN_IF_ERROR(Run("lease a webhook", [&](pqxx::work& work) {
            work.exec_params(sql_.create_webhook, webhook_id);
            const pqxx::result rows =
                work.exec_params(sql_.lease_webhook, webhook_id, holder, now_us, lease_until_us);
            if (!rows.empty()) state = PgWebhookFrom(webhook_id, rows[0]);
        }));
        return state;
    }

    absl::Status SaveWebhook(const std::string& holder, const WebhookState& state,
                             DeliveryRecord* attempt) override {
        return Run("save a webhook", [&](pqxx::work& work) {
            const pqxx::result saved = work.exec_params(
                sql_.save_webhook, state.webhook_id, holder, state.cursor, state.last_delivery_us,
                state.failing_attempts, state.last_error, state.next_attempt_us);
            if (saved.affected_rows() != 1) throw Refused{LostLease(state.webhook_id)};
            if (attempt == nullptr) return;
            const DeliveryRecord& d = *attempt;
            attempt->id = work.exec_params(sql_.insert_delivery, d.webhook_id, d.alert_id,
                                           d.attempt, d.time_us, d.outcome, d.http_status, d.error,
                                           d.latency_ms, d.delay_ms)[0][0]
                              .as<std::int64_t>();
        });
    }

    absl::Status ReleaseWebhook(const std::string& webhook_id, const std::string& holder) override {
        return Run("release a webhook", [&](pqxx::work& work) {
            work.exec_params(sql_.release_webhook, webhook_id, holder);
        });
    }

    absl::StatusOr<std::vector<WebhookState>> WebhookStates(
        const std::vector<std::string>& webhook_ids) override {
        std::vector<WebhookState> out;
        SOILVOL_RETURN_IF_ERROR(Run("read webhooks", [&](pqxx::work& work) {
            for (const std::string& id : webhook_ids) {
                const pqxx::result rows = work.exec_params(sql_.webhook_state, id);
                if (rows.empty()) continue;
                out.push_back(PgWebhookFrom(id, rows[0]));
                out.back().pending = rows[0][5].as<std::int64_t>();
            }
        }));
        return out;
    }

    absl::StatusOr<std::vector<DeliveryRecord>> ListDeliveries(
        const DeliveryQuery& query) override {
        std::vector<DeliveryRecord> out;
        SOILVOL_RETURN_IF_ERROR(Run("list deliveries", [&](pqxx::work& work) {
            const pqxx::result rows =
                work.exec_params(sql_.list_deliveries, query.webhook_id, query.alert_id,
                                 query.before_id.value_or(std::numeric_limits<std::int64_t>::max()),
                                 static_cast<std::int64_t>(query.limit));
            for (const pqxx::row& row : rows) out.push_back(PgDeliveryFrom(row));
        }));
        return out;
    }

    const char* kind() const override { return "postgresql"; }

  private:
    /// Runs `body` in a transaction and commits it, reconnecting once when the connection
    /// broke since the last call (a restarted server).
    template <typename Body>
    absl::Status Run(const char* what, Body body) {
        std::lock_guard<std::mutex> lock(mutex_);
        for (int attempt = 0;; ++attempt) {
            try {
                if (connection_ == nullptr || !connection_->is_open()) {
                    connection_ = std::make_unique<pqxx::connection>(url_);
                }
                pqxx::work work(*connection_);
                body(work);
                work.commit();
                return absl::OkStatus();
            } catch (const pqxx::broken_connection& e) {
                connection_.reset();
                if (attempt > 0) return PgError(e, what);
            } catch (const Refused& e) {
                return e.status;
            } catch (const std::exception& e) {
                return PgError(e, what);
            }
        }
    }

    const std::string url_;
    const AlertSql sql_{"soilvol_", false};
    const LoadEventSql events_sql_{"soilvol_", false};
    std::mutex mutex_;
    std::unique_ptr<pqxx::connection> connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<RecordStore>> OpenPostgresRecordStore(const std::string& url) {
    auto store = std::make_unique<PostgresRecordStore>(url);
    if (absl::Status init = store->Init(); !init.ok()) {
        return absl::UnavailableError(
            absl::StrCat("records: cannot use ", RedactedUrl(url), ": ", init.message()));
    }
    return store;
}

}  // namespace soilvol::server
