#include <sqlite3.h>

#include <mutex>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
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
)sql";

// Databases made before records named their registration gain the column (older records: '').
constexpr const char* kSqliteRegistrations = R"sql(
CREATE INDEX IF NOT EXISTS estimates_by_registration
    ON estimates (container_id, registration_id, id);
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
    std::int64_t Int(int column) const { return sqlite3_column_int64(stmt_, column); }
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
    if (with_payload) record.payload = row.Text(5);
    return record;
}

constexpr const char* kColumns = "id, container_id, create_time_us, request_id, registration_id";

class SqliteRecordStore final : public RecordStore {
  public:
    explicit SqliteRecordStore(sqlite3* db) : db_(db) {}
    ~SqliteRecordStore() override { sqlite3_close_v2(db_); }

    absl::Status Init() {
        for (const char* pragma : {"PRAGMA journal_mode=WAL", "PRAGMA synchronous=FULL"}) {
            SOILVOL_RETURN_IF_ERROR(Exec(pragma));
        }
        SOILVOL_RETURN_IF_ERROR(Exec(kSqliteSchema));
        SOILVOL_ASSIGN_OR_RETURN(const bool has_column, HasRegistrationColumn());
        if (!has_column) {
            SOILVOL_RETURN_IF_ERROR(
                Exec("ALTER TABLE estimates ADD COLUMN registration_id TEXT NOT NULL DEFAULT ''"));
        }
        return Exec(kSqliteRegistrations);
    }

    absl::Status Append(std::vector<EstimateRecord>& records) override {
        std::lock_guard<std::mutex> lock(mutex_);
        SOILVOL_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
        absl::Status status = Insert(records);
        if (status.ok()) status = Exec("COMMIT");
        if (!status.ok()) {
            Exec("ROLLBACK").IgnoreError();
            for (EstimateRecord& record : records) record.id = 0;
        }
        return status;
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
        Statement purge(db_, "DELETE FROM estimates WHERE container_id = ?1");
        SOILVOL_RETURN_IF_ERROR(purge.Prepared("delete a container's records"));
        purge.Bind(1, container_id);
        SOILVOL_RETURN_IF_ERROR(purge.Step("delete a container's records").status());
        return static_cast<std::int64_t>(sqlite3_changes(db_));
    }

    const char* kind() const override { return "sqlite"; }

  private:
    absl::StatusOr<bool> HasRegistrationColumn() {
        Statement columns(db_,
                          "SELECT 1 FROM pragma_table_info('estimates') WHERE name = "
                          "'registration_id'");
        SOILVOL_RETURN_IF_ERROR(columns.Prepared("read the schema"));
        return columns.Step("read the schema");
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
                         "payload, registration_id) VALUES (?1, ?2, ?3, ?4, ?5)");
        SOILVOL_RETURN_IF_ERROR(insert.Prepared("insert"));
        for (EstimateRecord& record : records) {
            insert.Bind(1, record.container_id);
            insert.Bind(2, record.create_time_us);
            insert.Bind(3, record.request_id);
            insert.BindBlob(4, record.payload);
            insert.Bind(5, record.registration_id);
            SOILVOL_RETURN_IF_ERROR(insert.Step("insert").status());
            record.id = sqlite3_last_insert_rowid(db_);
            insert.Reset();
        }
        return absl::OkStatus();
    }

    sqlite3* db_;
    std::mutex mutex_;
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
