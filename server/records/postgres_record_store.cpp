#include <memory>
#include <mutex>
#include <pqxx/pqxx>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
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
)sql";

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
    if (with_payload) record.payload = pqxx::binarystring(row[5]).str();
    return record;
}

class PostgresRecordStore final : public RecordStore {
  public:
    explicit PostgresRecordStore(std::string url) : url_(std::move(url)) {}

    absl::Status Init() {
        return Run("create the schema", [](pqxx::work& work) { work.exec(kPostgresSchema); });
    }

    absl::Status Append(std::vector<EstimateRecord>& records) override {
        absl::Status status = Run("append", [&records](pqxx::work& work) {
            work.exec_params("SELECT pg_advisory_xact_lock($1)", kInsertLock);
            for (EstimateRecord& record : records) {
                const pqxx::binarystring payload(record.payload.data(), record.payload.size());
                const pqxx::result id = work.exec_params(
                    "INSERT INTO soilvol_estimates (container_id, create_time_us, request_id, "
                    "payload, registration_id) VALUES ($1, $2, $3, $4, $5) RETURNING id",
                    record.container_id, record.create_time_us, record.request_id, payload,
                    record.registration_id);
                record.id = id[0][0].as<std::int64_t>();
            }
        });
        if (!status.ok()) {
            for (EstimateRecord& record : records) record.id = 0;
        }
        return status;
    }

    absl::StatusOr<EstimateRecord> Get(const std::string& container_id, std::int64_t id) override {
        std::optional<EstimateRecord> found;
        SOILVOL_RETURN_IF_ERROR(Run("get", [&](pqxx::work& work) {
            const pqxx::result rows = work.exec_params(
                "SELECT id, container_id, create_time_us, request_id, registration_id, payload "
                "FROM soilvol_estimates WHERE id = $1 AND container_id = $2",
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
            "SELECT id, container_id, create_time_us, request_id, registration_id",
            query.with_payload ? ", payload" : "",
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
        }));
        return deleted;
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
            } catch (const std::exception& e) {
                return PgError(e, what);
            }
        }
    }

    const std::string url_;
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
