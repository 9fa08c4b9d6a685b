#include <sqlite3.h>

#include <algorithm>
#include <mutex>
#include <utility>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "server/records/alert_sql.hpp"
#include "server/records/load_event_sql.hpp"
#include "server/records/record_store.hpp"

namespace soilvol::server {
namespace {

constexpr int kBusyTimeoutMs = 5000;

constexpr const char* kSqliteSchema = R"sql(
CREATE TABLE IF NOT EXISTS estimates (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    container_id TEXT NOT NULL,
    create_time_us INTEGER NOT NULL,
    request_id TEXT NOT NULL,
    payload BLOB NOT NULL,
    registration_id TEXT NOT NULL DEFAULT '');
CREATE INDEX IF NOT EXISTS estimates_by_container ON estimates (container_id, id);
CREATE INDEX IF NOT EXISTS estimates_by_time ON estimates (create_time_us);
CREATE TABLE IF NOT EXISTS loads (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    load_id TEXT NOT NULL UNIQUE,
    haul_unit_id TEXT NOT NULL,
    body_container_id TEXT NOT NULL,
    state INTEGER NOT NULL,
    close_reason INTEGER NOT NULL,
    create_time_us INTEGER NOT NULL,
    update_time_us INTEGER NOT NULL,
    close_time_us INTEGER NOT NULL,
    last_activity_us INTEGER NOT NULL,
    revision INTEGER NOT NULL,
    passes INTEGER NOT NULL,
    request_id TEXT NOT NULL,
    payload BLOB NOT NULL);
CREATE TABLE IF NOT EXISTS production (
    bucket_us INTEGER NOT NULL,
    container_id TEXT NOT NULL,
    haul_unit_id TEXT NOT NULL,
    material TEXT NOT NULL,
    passes INTEGER NOT NULL,
    loads INTEGER NOT NULL,
    volume_m3 REAL NOT NULL,
    bank_volume_m3 REAL NOT NULL,
    mass_kg REAL NOT NULL,
    mass_passes INTEGER NOT NULL,
    fill_ratio_sum REAL NOT NULL,
    status_0 INTEGER NOT NULL, status_1 INTEGER NOT NULL, status_2 INTEGER NOT NULL,
    status_3 INTEGER NOT NULL, status_4 INTEGER NOT NULL, status_5 INTEGER NOT NULL,
    status_6 INTEGER NOT NULL,
    PRIMARY KEY (bucket_us, container_id, haul_unit_id, material)) WITHOUT ROWID;
CREATE TABLE IF NOT EXISTS production_rollup (
    granularity_us INTEGER NOT NULL,
    dimension INTEGER NOT NULL,
    bucket_us INTEGER NOT NULL,
    key TEXT NOT NULL,
    passes INTEGER NOT NULL,
    loads INTEGER NOT NULL,
    volume_m3 REAL NOT NULL,
    bank_volume_m3 REAL NOT NULL,
    mass_kg REAL NOT NULL,
    mass_passes INTEGER NOT NULL,
    fill_ratio_sum REAL NOT NULL,
    status_0 INTEGER NOT NULL, status_1 INTEGER NOT NULL, status_2 INTEGER NOT NULL,
    status_3 INTEGER NOT NULL, status_4 INTEGER NOT NULL, status_5 INTEGER NOT NULL,
    status_6 INTEGER NOT NULL,
    PRIMARY KEY (granularity_us, dimension, bucket_us, key)) WITHOUT ROWID;
CREATE UNIQUE INDEX IF NOT EXISTS loads_open_by_haul_unit ON loads (haul_unit_id) WHERE state = 1;
CREATE INDEX IF NOT EXISTS loads_by_haul_unit ON loads (haul_unit_id, seq);
)sql";

// Columns added since the first schema: older databases gain them (their records: '' / 0).
struct AddedColumn {
    const char* table;
    const char* column;
    const char* alter;
};
constexpr AddedColumn kAddedColumns[] = {
    {"estimates", "registration_id",
     "ALTER TABLE estimates ADD COLUMN registration_id TEXT NOT NULL DEFAULT ''"},
    {"estimates", "load_id", "ALTER TABLE estimates ADD COLUMN load_id TEXT NOT NULL DEFAULT ''"},
    {"estimates", "load_role",
     "ALTER TABLE estimates ADD COLUMN load_role INTEGER NOT NULL DEFAULT 0"},
    {"loads", "passes", "ALTER TABLE loads ADD COLUMN passes INTEGER NOT NULL DEFAULT 0"},
    // Loads from before alerts count as judged; CreateLoad writes 0.
    {"loads", "judged", "ALTER TABLE loads ADD COLUMN judged INTEGER NOT NULL DEFAULT 1"},
};

constexpr const char* kSqliteAddedIndexes = R"sql(
CREATE INDEX IF NOT EXISTS estimates_by_registration
    ON estimates (container_id, registration_id, id);
CREATE INDEX IF NOT EXISTS estimates_by_load ON estimates (load_id, id) WHERE load_id != '';
)sql";

absl::Status SqliteError(sqlite3* db, int code, const char* what) {
    const std::string message =
        absl::StrCat("records (sqlite): ", what, ": ", db != nullptr ? sqlite3_errmsg(db) : "",
                     " (", sqlite3_errstr(code), ")");
    switch (code & 0xff) {
        case SQLITE_BUSY:
        case SQLITE_LOCKED:
        case SQLITE_IOERR:
        case SQLITE_FULL:
        case SQLITE_CANTOPEN:
        case SQLITE_READONLY:
            return absl::UnavailableError(message);
        case SQLITE_CORRUPT:
        case SQLITE_NOTADB:
            return absl::DataLossError(message);
        default:
            return absl::InternalError(message);
    }
}

/// A prepared statement, finalized on scope exit.
class Statement {
  public:
    Statement(sqlite3* db, const std::string& sql) : db_(db) {
        code_ = sqlite3_prepare_v2(db, sql.c_str(), static_cast<int>(sql.size()), &stmt_, nullptr);
    }
    ~Statement() { sqlite3_finalize(stmt_); }
    Statement(const Statement&) = delete;
    Statement& operator=(const Statement&) = delete;

    absl::Status Prepared(const char* what) const {
        return code_ == SQLITE_OK ? absl::OkStatus() : SqliteError(db_, code_, what);
    }
    void Bind(int index, std::int64_t value) { sqlite3_bind_int64(stmt_, index, value); }
    void Bind(int index, const std::string& text) {
        sqlite3_bind_text(stmt_, index, text.data(), static_cast<int>(text.size()),
                          SQLITE_TRANSIENT);
    }
    void BindBlob(int index, const std::string& bytes) {
        sqlite3_bind_blob(stmt_, index, bytes.data(), static_cast<int>(bytes.size()),
                          SQLITE_TRANSIENT);
    }
    /// SQLITE_ROW or SQLITE_DONE, else the error.
    absl::StatusOr<bool> Step(const char* what) {
        const int code = sqlite3_step(stmt_);
        if (code == SQLITE_ROW) return true;
        if (code == SQLITE_DONE) return false;
        return SqliteError(db_, code, what);
    }
    void Reset() {
        sqlite3_reset(stmt_);
        sqlite3_clear_bindings(stmt_);
    }
    void Bind(int index, double value) { sqlite3_bind_double(stmt_, index, value); }
    std::int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }
    double Real(int column) const { return sqlite3_column_double(stmt_, column); }
    std::string Text(int column) const {
        const void* data = sqlite3_column_blob(stmt_, column);
        const int size = sqlite3_column_bytes(stmt_, column);
        return data != nullptr ? std::string(static_cast<const char*>(data), size) : std::string();
    }

  private:
    sqlite3* db_;
    sqlite3_stmt* stmt_ = nullptr;
    int code_ = SQLITE_OK;
};

EstimateRecord RecordFrom(const Statement& row, bool with_payload) {
    EstimateRecord record;
    record.id = row.Int(0);
    record.container_id = row.Text(1);
    record.create_time_us = row.Int(2);
    record.request_id = row.Text(3);
    record.registration_id = row.Text(4);
    if (!row.Text(5).empty()) {
        record.load = LoadLink{row.Text(5), static_cast<int>(row.Int(6)), 0};
    }
    if (with_payload) record.payload = row.Text(7);
    return record;
}

constexpr const char* kColumns =
    "id, container_id, create_time_us, request_id, registration_id, load_id, load_role";

constexpr const char* kLoadColumns =
    "seq, load_id, haul_unit_id, body_container_id, state, close_reason, create_time_us, "
    "update_time_us, close_time_us, last_activity_us, revision, request_id, payload, passes";

LoadRecord LoadFrom(const Statement& row) {
    LoadRecord load;
    load.seq = row.Int(0);
    load.load_id = row.Text(1);
    load.haul_unit_id = row.Text(2);
    load.body_container_id = row.Text(3);
    load.state = static_cast<int>(row.Int(4));
    load.close_reason = static_cast<int>(row.Int(5));
    load.create_time_us = row.Int(6);
    load.update_time_us = row.Int(7);
    load.close_time_us = row.Int(8);
    load.last_activity_us = row.Int(9);
    load.revision = row.Int(10);
    load.request_id = row.Text(11);
    load.payload = row.Text(12);
    load.passes = row.Int(13);
    return load;
}

/// A rollup row (RollupSelectSql) of `dimension`.
ProductionCell CellFrom(const Statement& row, int dimension) {
    ProductionCell cell;
    cell.bucket_us = row.Int(0);
    SetCellKey(dimension, row.Text(1), cell);
    cell.passes = row.Int(2);
    cell.loads = row.Int(3);
    cell.volume_m3 = row.Real(4);
    cell.bank_volume_m3 = row.Real(5);
    cell.mass_kg = row.Real(6);
    cell.mass_passes = row.Int(7);
    cell.fill_ratio_sum = row.Real(8);
    for (int i = 0; i < ProductionCell::kStatuses; ++i) cell.statuses[i] = row.Int(9 + i);
    return cell;
}

/// Binds a cell's values from parameter `first` on (ProductionUpsertSql, RollupUpsertSql).
void BindValues(Statement& statement, int first, const ProductionCell& cell) {
    statement.Bind(first, cell.passes);
    statement.Bind(first + 1, cell.loads);
    statement.Bind(first + 2, cell.volume_m3);
    statement.Bind(first + 3, cell.bank_volume_m3);
    statement.Bind(first + 4, cell.mass_kg);
    statement.Bind(first + 5, cell.mass_passes);
    statement.Bind(first + 6, cell.fill_ratio_sum);
    for (int i = 0; i < ProductionCell::kStatuses; ++i) {
        statement.Bind(first + 7 + i, cell.statuses[i]);
    }
}

AlertRecord AlertFrom(const Statement& row) {
    AlertRecord alert;
    alert.id = row.Int(0);
    alert.kind = static_cast<int>(row.Int(1));
    alert.create_time_us = row.Int(2);
    alert.container_id = row.Text(3);
    alert.estimate_id = row.Int(4);
    alert.load_id = row.Text(5);
    alert.haul_unit_id = row.Text(6);
    alert.request_id = row.Text(7);
    alert.message = row.Text(8);
    alert.value = row.Real(9);
    alert.threshold = row.Real(10);
    return alert;
}

/// A webhook's state from (cursor_id, last_delivery_us, failing_attempts, last_error,
/// next_attempt_us).
WebhookState WebhookFrom(const std::string& webhook_id, const Statement& row) {
    WebhookState state;
    state.webhook_id = webhook_id;
    state.cursor = row.Int(0);
    state.last_delivery_us = row.Int(1);
    state.failing_attempts = static_cast<int>(row.Int(2));
    state.last_error = row.Text(3);
    state.next_attempt_us = row.Int(4);
    return state;
}

DeliveryRecord DeliveryFrom(const Statement& row) {
    DeliveryRecord delivery;
    delivery.id = row.Int(0);
    delivery.webhook_id = row.Text(1);
    delivery.alert_id = row.Int(2);
    delivery.attempt = static_cast<int>(row.Int(3));
    delivery.time_us = row.Int(4);
    delivery.outcome = static_cast<int>(row.Int(5));
    delivery.http_status = static_cast<int>(row.Int(6));
    delivery.error = row.Text(7);
    delivery.latency_ms = row.Real(8);
    delivery.delay_ms = row.Real(9);
    return delivery;
}

void BindDelivery(Statement& insert, const DeliveryRecord& d) {
    insert.Bind(1, d.webhook_id);
    insert.Bind(2, d.alert_id);
    insert.Bind(3, std::int64_t{d.attempt});
    insert.Bind(4, d.time_us);
    insert.Bind(5, std::int64_t{d.outcome});
    insert.Bind(6, std::int64_t{d.http_status});
    insert.Bind(7, d.error);
    insert.Bind(8, d.latency_ms);
    insert.Bind(9, d.delay_ms);
}

/// A load's columns from load_id to payload (as the loads table holds them) from `first` on.
void BindLoad(Statement& statement, int first, const LoadRecord& load) {
    statement.Bind(first, load.load_id);
    statement.Bind(first + 1, load.haul_unit_id);
    statement.Bind(first + 2, load.body_container_id);
    statement.Bind(first + 3, std::int64_t{load.state});
    statement.Bind(first + 4, std::int64_t{load.close_reason});
    statement.Bind(first + 5, load.create_time_us);
    statement.Bind(first + 6, load.update_time_us);
    statement.Bind(first + 7, load.close_time_us);
    statement.Bind(first + 8, load.last_activity_us);
    statement.Bind(first + 9, load.revision);
    statement.Bind(first + 10, load.request_id);
    statement.BindBlob(first + 11, load.payload);
}

class SqliteRecordStore final : public RecordStore {
  public:
    explicit SqliteRecordStore(sqlite3* db) : db_(db) {}
    ~SqliteRecordStore() override { sqlite3_close_v2(db_); }

    absl::Status Init() {
        for (const char* pragma : {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL"}) {
            SOILVOL_RETURN_IF_ERROR(Exec(pragma));
        }
        SOILVOL_RETURN_IF_ERROR(Exec(kSqliteSchema));
        for (const AddedColumn& added : kAddedColumns) {
            SOILVOL_ASSIGN_OR_RETURN(const bool has_column, HasColumn(added.table, added.column));
            if (!has_column) SOILVOL_RETURN_IF_ERROR(Exec(added.alter));
        }
        SOILVOL_RETURN_IF_ERROR(Exec(kSqliteAddedIndexes));
        SOILVOL_RETURN_IF_ERROR(Exec(sql_.schema.c_str()));
        SOILVOL_RETURN_IF_ERROR(Exec(events_sql_.schema.c_str()));
        // A database made before the rollup: made from the fine table once.
        Statement missing(db_,
                          "SELECT EXISTS (SELECT 1 FROM production) AND NOT EXISTS (SELECT 1 "
                          "FROM production_rollup)");
        SOILVOL_RETURN_IF_ERROR(missing.Prepared("read the schema"));
        SOILVOL_RETURN_IF_ERROR(missing.Step("read the schema").status());
        if (missing.Int(0) == 0) return absl::OkStatus();
        return InTransaction([this] { return RebuildRollup(); });
    }

    absl::Status Append(std::vector<EstimateRecord>& records) override {
        std::lock_guard<std::mutex> lock(mutex_);
        const absl::Status status = InTransaction([&] { return Insert(records); });
        if (!status.ok()) {
            for (EstimateRecord& record : records) record.id = 0;
        }
        return status;
    }

    absl::Status CreateLoad(LoadRecord& load, std::int64_t idle_us) override {
        std::lock_guard<std::mutex> lock(mutex_);
        return InTransaction([&]() -> absl::Status {
            SOILVOL_ASSIGN_OR_RETURN(std::optional<LoadRecord> taken, ReadLoad(load.load_id));
            if (taken) {
                return absl::AlreadyExistsError(
                    absl::StrCat("load_id: load '", load.load_id, "' already exists"));
            }
            Statement open(db_, absl::StrCat("SELECT ", kLoadColumns,
                                             " FROM loads WHERE haul_unit_id = ?1 AND state = 1"));
            SOILVOL_RETURN_IF_ERROR(open.Prepared("find the open load"));
            open.Bind(1, load.haul_unit_id);
            SOILVOL_ASSIGN_OR_RETURN(const bool found, open.Step("find the open load"));
            if (found) {
                LoadRecord previous = LoadFrom(open);
                CloseLoadAt(previous, LoadRecord::kNewLoad, load.create_time_us, idle_us);
                SOILVOL_RETURN_IF_ERROR(WriteLoadState(previous));
                SOILVOL_RETURN_IF_ERROR(KeepClosed(previous));
            }
            Statement insert(
                db_,
                "INSERT INTO loads (load_id, haul_unit_id, body_container_id, state, "
                "close_reason, create_time_us, update_time_us, close_time_us, "
                "last_activity_us, revision, request_id, payload, passes, judged) VALUES "
                "(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, 0, 0)");
            SOILVOL_RETURN_IF_ERROR(insert.Prepared("create a load"));
            BindLoad(insert, 1, load);
            SOILVOL_RETURN_IF_ERROR(insert.Step("create a load").status());
            load.seq = sqlite3_last_insert_rowid(db_);
            LoadEventRecord created =
                LoadEventOf(load, LoadEventRecord::kCreated, load.create_time_us);
            SOILVOL_RETURN_IF_ERROR(InsertLoadEvent(created));
            return absl::OkStatus();
        });
    }

    absl::StatusOr<LoadRecord> GetLoad(const std::string& load_id) override {
        std::lock_guard<std::mutex> lock(mutex_);
        SOILVOL_ASSIGN_OR_RETURN(std::optional<LoadRecord> load, ReadLoad(load_id));
        if (!load) return absl::NotFoundError(absl::StrCat("load '", load_id, "' not found"));
        return *std::move(load);
    }

    absl::StatusOr<std::vector<LoadRecord>> ListLoads(const LoadQuery& query) override {
        std::string sql = absl::StrCat("SELECT ", kLoadColumns, " FROM loads WHERE seq < ?1");
        if (!query.haul_unit_id.empty()) sql += " AND haul_unit_id = ?2";
        if (query.state == LoadRecord::kOpen) sql += " AND state = 1 AND last_activity_us >= ?3";
        if (query.state == LoadRecord::kClosed) sql += " AND (state = 2 OR last_activity_us < ?3)";
        sql += " ORDER BY seq DESC LIMIT ?4";
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("list loads"));
        select.Bind(1, query.before_seq.value_or(std::numeric_limits<std::int64_t>::max()));
        if (!query.haul_unit_id.empty()) select.Bind(2, query.haul_unit_id);
        select.Bind(3, query.open_since_us);
        select.Bind(4, static_cast<std::int64_t>(query.limit));
        std::vector<LoadRecord> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("list loads"));
            if (!row) break;
            out.push_back(LoadFrom(select));
        }
        return out;
    }

    absl::StatusOr<LoadRecord> CloseLoad(const std::string& load_id, std::int64_t now_us,
                                         std::int64_t idle_us,
                                         std::optional<std::int64_t> revision) override {
        std::lock_guard<std::mutex> lock(mutex_);
        LoadRecord closed;
        const absl::Status done = InTransaction([&]() -> absl::Status {
            SOILVOL_ASSIGN_OR_RETURN(std::optional<LoadRecord> load, ReadLoad(load_id));
            if (!load) return absl::NotFoundError(absl::StrCat("load '", load_id, "' not found"));
            SOILVOL_RETURN_IF_ERROR(CheckLoadRevision(*load, revision));
            if (CloseLoadAt(*load, LoadRecord::kExplicit, now_us, idle_us)) {
                SOILVOL_RETURN_IF_ERROR(WriteLoadState(*load));
                SOILVOL_RETURN_IF_ERROR(KeepClosed(*load));
            }
            closed = *std::move(load);
            return absl::OkStatus();
        });
        SOILVOL_RETURN_IF_ERROR(done);
        return closed;
    }

    absl::StatusOr<std::vector<ProductionCell>> ProductionCells(
        std::int64_t start_us, std::int64_t end_us, int dimension,
        std::int64_t granularity_us) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, RollupSelectSql("production_rollup", '?'));
        SOILVOL_RETURN_IF_ERROR(select.Prepared("read production"));
        select.Bind(1, granularity_us);
        select.Bind(2, std::int64_t{dimension});
        select.Bind(3, start_us);
        select.Bind(4, end_us);
        std::vector<ProductionCell> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("read production"));
            if (!row) break;
            out.push_back(CellFrom(select, dimension));
        }
        return out;
    }

    absl::StatusOr<std::vector<EstimateRecord>> LoadEstimates(
        const std::vector<std::string>& load_ids) override {
        std::lock_guard<std::mutex> lock(mutex_);
        std::vector<EstimateRecord> out;
        for (const std::string& load_id : load_ids) {
            SOILVOL_RETURN_IF_ERROR(
                ReadLoadRecords(load_id, std::numeric_limits<std::int64_t>::max(), out));
        }
        return out;
    }

    absl::StatusOr<EstimateRecord> Get(const std::string& container_id, std::int64_t id) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, absl::StrCat("SELECT ", kColumns, ", payload",
                                           " FROM estimates WHERE id = ?1 AND container_id = ?2"));
        SOILVOL_RETURN_IF_ERROR(select.Prepared("get"));
        select.Bind(1, id);
        select.Bind(2, container_id);
        SOILVOL_ASSIGN_OR_RETURN(const bool found, select.Step("get"));
        if (!found) {
            return absl::NotFoundError(
                absl::StrCat("estimate ", id, " of container '", container_id, "' not found"));
        }
        return RecordFrom(select, true);
    }

    absl::StatusOr<std::vector<EstimateRecord>> List(const RecordQuery& query) override {
        const bool ascending = query.after_id.has_value();
        std::string sql =
            absl::StrCat("SELECT ", kColumns, query.with_payload ? ", payload" : "",
                         " FROM estimates WHERE id > ?1 AND id < ?2 AND create_time_us >= ?3 AND "
                         "create_time_us < ?4");
        if (!query.container_id.empty()) sql += " AND container_id = ?5";
        if (!query.registration_id.empty()) sql += " AND registration_id = ?7";
        absl::StrAppend(&sql, " ORDER BY id ", ascending ? "ASC" : "DESC", " LIMIT ?6");
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("list"));
        select.Bind(1, query.after_id.value_or(0));
        select.Bind(2, query.before_id.value_or(std::numeric_limits<std::int64_t>::max()));
        select.Bind(3, query.start_time_us);
        select.Bind(4, query.end_time_us);
        if (!query.container_id.empty()) select.Bind(5, query.container_id);
        select.Bind(6, static_cast<std::int64_t>(query.limit));
        if (!query.registration_id.empty()) select.Bind(7, query.registration_id);
        std::vector<EstimateRecord> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("list"));
            if (!row) break;
            out.push_back(RecordFrom(select, query.with_payload));
        }
        return out;
    }

    absl::StatusOr<std::int64_t> Prune(
        const RetentionPolicy& policy, std::int64_t now_us,
        const std::optional<std::vector<std::string>>& containers) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement old(db_, "DELETE FROM estimates WHERE create_time_us < ?1");
        SOILVOL_RETURN_IF_ERROR(old.Prepared("prune by age"));
        old.Bind(
            1,
            now_us - std::chrono::duration_cast<std::chrono::microseconds>(policy.max_age).count());
        SOILVOL_RETURN_IF_ERROR(old.Step("prune by age").status());
        std::int64_t deleted = sqlite3_changes(db_);
        Statement old_loads(db_, "DELETE FROM loads WHERE update_time_us < ?1 AND state = 2");
        SOILVOL_RETURN_IF_ERROR(old_loads.Prepared("prune loads by age"));
        old_loads.Bind(
            1,
            now_us - std::chrono::duration_cast<std::chrono::microseconds>(policy.max_age).count());
        SOILVOL_RETURN_IF_ERROR(old_loads.Step("prune loads by age").status());
        for (const std::string* sql :
             {&sql_.prune_alerts, &sql_.prune_deliveries, &events_sql_.prune_events}) {
            Statement prune(db_, *sql);
            SOILVOL_RETURN_IF_ERROR(prune.Prepared("prune alerts by age"));
            prune.Bind(
                1,
                now_us -
                    std::chrono::duration_cast<std::chrono::microseconds>(policy.max_age).count());
            SOILVOL_RETURN_IF_ERROR(prune.Step("prune alerts by age").status());
        }
        if (!containers) {
            Statement surplus(db_,
                              "DELETE FROM estimates WHERE id IN (SELECT id FROM (SELECT id, "
                              "ROW_NUMBER() OVER (PARTITION BY container_id ORDER BY id DESC) "
                              "AS n FROM estimates) WHERE n > ?1)");
            SOILVOL_RETURN_IF_ERROR(surplus.Prepared("prune by count"));
            surplus.Bind(1, policy.max_per_container);
            SOILVOL_RETURN_IF_ERROR(surplus.Step("prune by count").status());
            return deleted + sqlite3_changes(db_);
        }
        for (const std::string& container_id : *containers) {
            // Older than the container's (max+1)-th newest; nothing when it has no more.
            Statement surplus(db_,
                              "DELETE FROM estimates WHERE container_id = ?1 AND id <= (SELECT "
                              "id FROM estimates WHERE container_id = ?1 ORDER BY id DESC "
                              "LIMIT 1 OFFSET ?2)");
            SOILVOL_RETURN_IF_ERROR(surplus.Prepared("prune by count"));
            surplus.Bind(1, container_id);
            surplus.Bind(2, policy.max_per_container);
            SOILVOL_RETURN_IF_ERROR(surplus.Step("prune by count").status());
            deleted += sqlite3_changes(db_);
        }
        return deleted;
    }

    absl::StatusOr<std::int64_t> DeleteContainer(const std::string& container_id) override {
        std::lock_guard<std::mutex> lock(mutex_);
        std::int64_t deleted = 0;
        const absl::Status done = InTransaction([&]() -> absl::Status {
            Statement purge(db_, "DELETE FROM estimates WHERE container_id = ?1");
            SOILVOL_RETURN_IF_ERROR(purge.Prepared("delete a container's records"));
            purge.Bind(1, container_id);
            SOILVOL_RETURN_IF_ERROR(purge.Step("delete a container's records").status());
            deleted = sqlite3_changes(db_);
            for (const std::string* sql : {&sql_.purge_alerts, &events_sql_.purge_events}) {
                Statement alerts(db_, *sql);
                SOILVOL_RETURN_IF_ERROR(alerts.Prepared("delete a container's alerts"));
                alerts.Bind(1, container_id);
                SOILVOL_RETURN_IF_ERROR(alerts.Step("delete a container's alerts").status());
            }
            Statement cells(db_, "DELETE FROM production WHERE container_id = ?1");
            SOILVOL_RETURN_IF_ERROR(cells.Prepared("delete a container's production"));
            cells.Bind(1, container_id);
            SOILVOL_RETURN_IF_ERROR(cells.Step("delete a container's production").status());
            return RebuildRollup();
        });
        SOILVOL_RETURN_IF_ERROR(done);
        return deleted;
    }

    absl::StatusOr<std::vector<LoadEventRecord>> ListLoadEvents(
        const LoadEventQuery& query) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, query.after_id ? events_sql_.list_after : events_sql_.list_newest);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("list load events"));
        select.Bind(1, query.after_id.value_or(0));
        select.Bind(2, query.container_id);
        select.Bind(3, query.haul_unit_id);
        select.Bind(4, static_cast<std::int64_t>(query.limit));
        std::vector<LoadEventRecord> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("list load events"));
            if (!row) break;
            LoadEventRecord& event = out.emplace_back();
            event.load = LoadFrom(select);
            event.id = select.Int(kLoadEventIdColumn);
            event.kind = static_cast<int>(select.Int(kLoadEventIdColumn + 1));
            event.time_us = select.Int(kLoadEventIdColumn + 2);
            event.container_id = select.Text(kLoadEventIdColumn + 3);
            event.estimate_id = select.Int(kLoadEventIdColumn + 4);
            event.through_estimate_id = select.Int(kLoadEventIdColumn + 5);
        }
        for (LoadEventRecord& event : out) {
            if (!query.with_records || event.through_estimate_id == 0) continue;
            SOILVOL_RETURN_IF_ERROR(
                ReadLoadRecords(event.load.load_id, event.through_estimate_id, event.records));
        }
        return out;
    }

    absl::StatusOr<std::vector<AlertRecord>> ListAlerts(const AlertQuery& query) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql_.ListAlertsSql(query.after_id.has_value()));
        SOILVOL_RETURN_IF_ERROR(select.Prepared("list alerts"));
        select.Bind(1, query.after_id.value_or(0));
        select.Bind(2, query.before_id.value_or(std::numeric_limits<std::int64_t>::max()));
        select.Bind(3, query.start_time_us);
        select.Bind(4, query.end_time_us);
        select.Bind(5, query.container_id);
        select.Bind(6, std::int64_t{query.kind});
        select.Bind(7, static_cast<std::int64_t>(query.limit));
        std::vector<AlertRecord> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("list alerts"));
            if (!row) break;
            out.push_back(AlertFrom(select));
        }
        return out;
    }

    absl::StatusOr<std::vector<std::string>> UnjudgedLoads(std::int64_t idle_before_us,
                                                           int limit) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql_.unjudged_loads);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("find loads to judge"));
        select.Bind(1, idle_before_us);
        select.Bind(2, std::int64_t{limit});
        std::vector<std::string> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("find loads to judge"));
            if (!row) break;
            out.push_back(select.Text(0));
        }
        return out;
    }

    absl::StatusOr<bool> JudgeLoad(const std::string& load_id,
                                   std::optional<AlertRecord>& alert) override {
        std::lock_guard<std::mutex> lock(mutex_);
        bool judged = false;
        const absl::Status done = InTransaction([&]() -> absl::Status {
            Statement mark(db_, sql_.judge_load);
            SOILVOL_RETURN_IF_ERROR(mark.Prepared("judge a load"));
            mark.Bind(1, load_id);
            SOILVOL_RETURN_IF_ERROR(mark.Step("judge a load").status());
            judged = sqlite3_changes(db_) == 1;
            if (!judged || !alert) return absl::OkStatus();
            return InsertAlert(*alert);
        });
        SOILVOL_RETURN_IF_ERROR(done);
        return judged;
    }

    absl::StatusOr<std::optional<WebhookState>> LeaseWebhook(const std::string& webhook_id,
                                                             const std::string& holder,
                                                             std::int64_t now_us,
                                                             std::int64_t lease_until_us) override {
        std::lock_guard<std::mutex> lock(mutex_);
        std::optional<WebhookState> state;
        const absl::Status done = InTransaction([&]() -> absl::Status {
            Statement create(db_, sql_.create_webhook);
            SOILVOL_RETURN_IF_ERROR(create.Prepared("lease a webhook"));
            create.Bind(1, webhook_id);
            SOILVOL_RETURN_IF_ERROR(create.Step("lease a webhook").status());
            Statement lease(db_, sql_.lease_webhook);
            SOILVOL_RETURN_IF_ERROR(lease.Prepared("lease a webhook"));
            lease.Bind(1, webhook_id);
            lease.Bind(2, holder);
            lease.Bind(3, now_us);
            lease.Bind(4, lease_until_us);
            SOILVOL_ASSIGN_OR_RETURN(const bool leased, lease.Step("lease a webhook"));
            if (leased) state = WebhookFrom(webhook_id, lease);
            return absl::OkStatus();
        });
        SOILVOL_RETURN_IF_ERROR(done);
        return state;
    }

    absl::Status SaveWebhook(const std::string& holder, const WebhookState& state,
                             DeliveryRecord* attempt) override {
        std::lock_guard<std::mutex> lock(mutex_);
        return InTransaction([&]() -> absl::Status {
            Statement save(db_, sql_.save_webhook);
            SOILVOL_RETURN_IF_ERROR(save.Prepared("save a webhook"));
            save.Bind(1, state.webhook_id);
            save.Bind(2, holder);
            save.Bind(3, state.cursor);
            save.Bind(4, state.last_delivery_us);
            save.Bind(5, std::int64_t{state.failing_attempts});
            save.Bind(6, state.last_error);
            save.Bind(7, state.next_attempt_us);
            SOILVOL_RETURN_IF_ERROR(save.Step("save a webhook").status());
            if (sqlite3_changes(db_) != 1) return LostLease(state.webhook_id);
            if (attempt == nullptr) return absl::OkStatus();
            Statement insert(db_, sql_.insert_delivery);
            SOILVOL_RETURN_IF_ERROR(insert.Prepared("log a delivery"));
            BindDelivery(insert, *attempt);
            SOILVOL_RETURN_IF_ERROR(insert.Step("log a delivery").status());
            attempt->id = insert.Int(0);
            return absl::OkStatus();
        });
    }

    absl::Status ReleaseWebhook(const std::string& webhook_id, const std::string& holder) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement release(db_, sql_.release_webhook);
        SOILVOL_RETURN_IF_ERROR(release.Prepared("release a webhook"));
        release.Bind(1, webhook_id);
        release.Bind(2, holder);
        return release.Step("release a webhook").status();
    }

    absl::StatusOr<std::vector<WebhookState>> WebhookStates(
        const std::vector<std::string>& webhook_ids) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql_.webhook_state);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("read webhooks"));
        std::vector<WebhookState> out;
        for (const std::string& id : webhook_ids) {
            select.Bind(1, id);
            SOILVOL_ASSIGN_OR_RETURN(const bool found, select.Step("read webhooks"));
            if (found) {
                out.push_back(WebhookFrom(id, select));
                out.back().pending = select.Int(5);
            }
            select.Reset();
        }
        return out;
    }

    absl::StatusOr<std::vector<DeliveryRecord>> ListDeliveries(
        const DeliveryQuery& query) override {
        std::lock_guard<std::mutex> lock(mutex_);
        Statement select(db_, sql_.list_deliveries);
        SOILVOL_RETURN_IF_ERROR(select.Prepared("list deliveries"));
        select.Bind(1, query.webhook_id);
        select.Bind(2, query.alert_id);
        select.Bind(3, query.before_id.value_or(std::numeric_limits<std::int64_t>::max()));
        select.Bind(4, static_cast<std::int64_t>(query.limit));
        std::vector<DeliveryRecord> out;
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("list deliveries"));
            if (!row) break;
            out.push_back(DeliveryFrom(select));
        }
        return out;
    }

    const char* kind() const override { return "sqlite"; }

  private:
    absl::StatusOr<bool> HasColumn(const char* table, const char* name) {
        Statement columns(db_, "SELECT 1 FROM pragma_table_info(?1) WHERE name = ?2");
        SOILVOL_RETURN_IF_ERROR(columns.Prepared("read the schema"));
        columns.Bind(1, std::string(table));
        columns.Bind(2, std::string(name));
        return columns.Step("read the schema");
    }

    /// Runs `body` in a write transaction (BEGIN IMMEDIATE: writers one at a time across
    /// processes), committed when it returns OK and rolled back otherwise.
    template <typename Body>
    absl::Status InTransaction(Body body) {
        SOILVOL_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
        absl::Status status = body();
        if (status.ok()) status = Exec("COMMIT");
        if (!status.ok()) Exec("ROLLBACK").IgnoreError();
        return status;
    }

    /// The records of `load_id` up to the id `upto`, oldest first, appended to `out`.
    absl::Status ReadLoadRecords(const std::string& load_id, std::int64_t upto,
                                 std::vector<EstimateRecord>& out) {
        Statement select(db_, absl::StrCat("SELECT ", kColumns,
                                           ", payload FROM estimates WHERE load_id = ?1 AND "
                                           "load_id != '' AND id <= ?2 ORDER BY id"));
        SOILVOL_RETURN_IF_ERROR(select.Prepared("read a load's records"));
        select.Bind(1, load_id);
        select.Bind(2, upto);
        while (true) {
            SOILVOL_ASSIGN_OR_RETURN(const bool row, select.Step("read a load's records"));
            if (!row) return absl::OkStatus();
            out.push_back(RecordFrom(select, true));
        }
    }

    absl::StatusOr<std::optional<LoadRecord>> ReadLoad(const std::string& load_id) {
        Statement select(db_,
                         absl::StrCat("SELECT ", kLoadColumns, " FROM loads WHERE load_id = ?1"));
        SOILVOL_RETURN_IF_ERROR(select.Prepared("read a load"));
        select.Bind(1, load_id);
        SOILVOL_ASSIGN_OR_RETURN(const bool found, select.Step("read a load"));
        if (!found) return std::optional<LoadRecord>();
        return std::optional<LoadRecord>(LoadFrom(select));
    }

    /// Writes what changes of a load after its create (state, times, revision).
    absl::Status WriteLoadState(const LoadRecord& load) {
        Statement update(db_,
                         "UPDATE loads SET state = ?2, close_reason = ?3, update_time_us = ?4, "
                         "close_time_us = ?5, last_activity_us = ?6, revision = ?7, passes = ?8 "
                         "WHERE load_id = ?1");
        SOILVOL_RETURN_IF_ERROR(update.Prepared("update a load"));
        update.Bind(1, load.load_id);
        update.Bind(2, std::int64_t{load.state});
        update.Bind(3, std::int64_t{load.close_reason});
        update.Bind(4, load.update_time_us);
        update.Bind(5, load.close_time_us);
        update.Bind(6, load.last_activity_us);
        update.Bind(7, load.revision);
        update.Bind(8, load.passes);
        return update.Step("update a load").status();
    }

    /// Whether `record` may join its load (see Append), the load's state written when it
    /// changes; sets `joined` (the load's haul unit, whether this is its first pass).
    absl::StatusOr<absl::Status> JoinLoad(const EstimateRecord& record, JoinedLoad* joined) {
        const LoadLink& link = *record.load;
        SOILVOL_ASSIGN_OR_RETURN(std::optional<LoadRecord> load, ReadLoad(link.load_id));
        if (!load) {
            return absl::NotFoundError(
                absl::StrCat("load_id: load '", link.load_id, "' not found"));
        }
        const bool idled = ApplyIdleClose(*load, record.create_time_us, link.idle_us);
        if (idled) SOILVOL_RETURN_IF_ERROR(KeepClosed(*load));
        absl::Status join = CheckJoin(*load, link);
        if (join.ok()) *joined = JoinLoadRecord(*load, link, record.create_time_us);
        if (join.ok() || idled) SOILVOL_RETURN_IF_ERROR(WriteLoadState(*load));
        return join;
    }

    /// A refused scan: its container's run grows, and at alert_after its alert is kept.
    absl::Status CountRefusal(EstimateRecord& record) {
        record.id = 0;
        Statement count(db_, sql_.count_refusal);
        SOILVOL_RETURN_IF_ERROR(count.Prepared("count a refusal"));
        count.Bind(1, record.container_id);
        SOILVOL_RETURN_IF_ERROR(count.Step("count a refusal").status());
        const std::int64_t run = count.Int(0);
        if (run != record.refusal->alert_after) return absl::OkStatus();
        return InsertAlert(record.refusal->alert);
    }

    /// A kept record: its alerts kept, its container's run of refusals over.
    absl::Status KeepAlerts(EstimateRecord& record) {
        Statement end(db_, sql_.end_refusals);
        SOILVOL_RETURN_IF_ERROR(end.Prepared("end a run of refusals"));
        end.Bind(1, record.container_id);
        SOILVOL_RETURN_IF_ERROR(end.Step("end a run of refusals").status());
        for (AlertRecord& alert : record.alerts) {
            alert.estimate_id = record.id;
            SOILVOL_RETURN_IF_ERROR(InsertAlert(alert));
        }
        return absl::OkStatus();
    }

    /// The event of a load just closed.
    absl::Status KeepClosed(const LoadRecord& load) {
        LoadEventRecord event = LoadEventOf(load, LoadEventRecord::kClosed, load.close_time_us);
        return InsertLoadEvent(event);
    }

    /// The event of a kept record that joined its load.
    absl::Status KeepJoined(const EstimateRecord& record, const JoinedLoad& joined) {
        LoadEventRecord event = LoadEventOf(
            joined.load,
            joined.body_scan ? LoadEventRecord::kBodyScanned : LoadEventRecord::kPassAdded,
            record.create_time_us, record.container_id);
        event.estimate_id = record.id;
        return InsertLoadEvent(event);
    }

    absl::Status InsertLoadEvent(LoadEventRecord& event) {
        const LoadRecord& load = event.load;
        Statement insert(db_, events_sql_.insert_event);
        SOILVOL_RETURN_IF_ERROR(insert.Prepared("keep a load event"));
        insert.Bind(1, std::int64_t{event.kind});
        insert.Bind(2, event.time_us);
        insert.Bind(3, event.container_id);
        insert.Bind(4, event.estimate_id);
        insert.Bind(5, load.seq);
        BindLoad(insert, 6, load);
        insert.Bind(18, load.passes);
        SOILVOL_RETURN_IF_ERROR(insert.Step("keep a load event").status());
        event.id = insert.Int(0);
        return absl::OkStatus();
    }

    absl::Status InsertAlert(AlertRecord& alert) {
        Statement insert(db_, sql_.insert_alert);
        SOILVOL_RETURN_IF_ERROR(insert.Prepared("keep an alert"));
        insert.Bind(1, std::int64_t{alert.kind});
        insert.Bind(2, alert.create_time_us);
        insert.Bind(3, alert.container_id);
        insert.Bind(4, alert.estimate_id);
        insert.Bind(5, alert.load_id);
        insert.Bind(6, alert.haul_unit_id);
        insert.Bind(7, alert.request_id);
        insert.Bind(8, alert.message);
        insert.Bind(9, alert.value);
        insert.Bind(10, alert.threshold);
        SOILVOL_RETURN_IF_ERROR(insert.Step("keep an alert").status());
        alert.id = insert.Int(0);
        return absl::OkStatus();
    }

    absl::Status Exec(const char* sql) {
        char* error = nullptr;
        const int code = sqlite3_exec(db_, sql, nullptr, nullptr, &error);
        sqlite3_free(error);
        return code == SQLITE_OK ? absl::OkStatus() : SqliteError(db_, code, sql);
    }

    absl::Status Insert(std::vector<EstimateRecord>& records) {
        Statement insert(db_,
                         "INSERT INTO estimates (container_id, create_time_us, request_id, "
                         "payload, registration_id, load_id, load_role) VALUES (?1, ?2, ?3, ?4, "
                         "?5, ?6, ?7)");
        SOILVOL_RETURN_IF_ERROR(insert.Prepared("insert"));
        Statement fine(db_, ProductionUpsertSql("production", '?'));
        SOILVOL_RETURN_IF_ERROR(fine.Prepared("add to production"));
        Statement rollup(db_, RollupUpsertSql("production_rollup", '?'));
        SOILVOL_RETURN_IF_ERROR(rollup.Prepared("add to production"));
        for (EstimateRecord& record : records) {
            if (record.refusal) {
                SOILVOL_RETURN_IF_ERROR(CountRefusal(record));
                continue;
            }
            JoinedLoad joined;
            if (record.load) {
                SOILVOL_ASSIGN_OR_RETURN(record.rejected, JoinLoad(record, &joined));
                if (!record.rejected.ok()) continue;
                insert.Bind(6, record.load->load_id);
                insert.Bind(7, std::int64_t{record.load->role});
            } else {
                insert.Bind(6, std::string());
                insert.Bind(7, std::int64_t{0});
            }
            insert.Bind(1, record.container_id);
            insert.Bind(2, record.create_time_us);
            insert.Bind(3, record.request_id);
            insert.BindBlob(4, record.payload);
            insert.Bind(5, record.registration_id);
            SOILVOL_RETURN_IF_ERROR(insert.Step("insert").status());
            record.id = sqlite3_last_insert_rowid(db_);
            insert.Reset();
            SOILVOL_RETURN_IF_ERROR(KeepAlerts(record));
            if (record.load) SOILVOL_RETURN_IF_ERROR(KeepJoined(record, joined));
            if (!joined.body_scan) {
                SOILVOL_RETURN_IF_ERROR(AddProduction(fine, rollup, record, joined));
            }
        }
        return absl::OkStatus();
    }

    absl::Status AddProduction(Statement& fine, Statement& rollup, const EstimateRecord& record,
                               const JoinedLoad& joined) {
        const ProductionCell cell =
            CellOf(record.measures, record.container_id, joined.haul_unit_id, record.create_time_us,
                   joined.first_pass);
        fine.Bind(1, cell.bucket_us);
        fine.Bind(2, cell.container_id);
        fine.Bind(3, cell.haul_unit_id);
        fine.Bind(4, cell.material);
        BindValues(fine, 5, cell);
        SOILVOL_RETURN_IF_ERROR(fine.Step("add to production").status());
        fine.Reset();
        for (const RollupKey& key : RollupKeysOf(cell)) {
            rollup.Bind(1, key.granularity_us);
            rollup.Bind(2, std::int64_t{key.dimension});
            rollup.Bind(3, key.bucket_us);
            rollup.Bind(4, key.key);
            BindValues(rollup, 5, cell);
            SOILVOL_RETURN_IF_ERROR(rollup.Step("add to production").status());
            rollup.Reset();
        }
        return absl::OkStatus();
    }

    /// The rollup made anew from the fine table (in the caller's transaction).
    absl::Status RebuildRollup() {
        for (const std::string& sql : RollupRebuildSql("production", "production_rollup")) {
            SOILVOL_RETURN_IF_ERROR(Exec(sql.c_str()));
        }
        return absl::OkStatus();
    }

    sqlite3* db_;
    std::mutex mutex_;
    const AlertSql sql_{"", true};
    const LoadEventSql events_sql_{"", true};
};

}  // namespace

absl::StatusOr<std::unique_ptr<RecordStore>> OpenSqliteRecordStore(
    const std::filesystem::path& path) {
    sqlite3* db = nullptr;
    const int code =
        sqlite3_open_v2(path.c_str(), &db,
                        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX, nullptr);
    if (code != SQLITE_OK) {
        const absl::Status status = absl::UnavailableError(
            absl::StrCat("records (sqlite): cannot open ", path.string(), ": ",
                         db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(code)));
        sqlite3_close_v2(db);
        return status;
    }
    sqlite3_busy_timeout(db, kBusyTimeoutMs);
    auto store = std::make_unique<SqliteRecordStore>(db);
    if (absl::Status init = store->Init(); !init.ok()) {
        return absl::UnavailableError(
            absl::StrCat("records (sqlite): cannot use ", path.string(), ": ", init.message()));
    }
    return store;
}

}  // namespace soilvol::server
