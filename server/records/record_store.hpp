#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/records/alert_record.hpp"
#include "server/records/load_record.hpp"
#include "server/records/production.hpp"

namespace soilvol::server {

/// One estimate as kept: the fields lists select and order by as columns, the API message
/// (a serialized soilvol.v1.Estimate) as the payload.
struct EstimateRecord {
    std::int64_t id = 0;  ///< set by the store: increasing in the order records were committed
    std::string container_id;
    std::int64_t create_time_us = 0;  ///< since the Unix epoch
    std::string request_id;
    /// The container's registration (Container.registration_id) the estimate was measured
    /// against; "" for records written before registrations had ids.
    std::string registration_id;
    std::string payload;
    /// The truck load the estimate belongs to (a pass or a body scan), if any.
    std::optional<LoadLink> load;
    /// What it adds to production (written, not read back).
    Measures measures;
    /// Set by Append for a record it did not keep (its id stays 0): FailedPrecondition for a
    /// pass to a closed load, NotFound for a load that does not exist.
    absl::Status rejected;
    /// The alerts this estimate raised: kept with it (their estimate_id and id set by Append).
    std::vector<AlertRecord> alerts;
    /// Set for a refused scan: Append counts it in its container's run of refusals (and keeps
    /// the refusal's alert when the run reaches alert_after) but keeps no record (id stays 0).
    std::optional<Refusal> refusal;
};

/// One change of a load as kept (soilvol.v1.LoadEvent): kinds are the proto's LoadEventKind
/// numbers. Written in the transaction of the change.
struct LoadEventRecord {
    static constexpr int kCreated = 1, kPassAdded = 2, kBodyScanned = 3, kClosed = 4;

    std::int64_t id = 0;  ///< set by the store: increasing in commit order, as estimate ids
    int kind = 0;
    std::int64_t time_us = 0;  ///< when the change took effect
    /// The pass's or body scan's container; the load's body container for the other kinds.
    std::string container_id;
    std::int64_t estimate_id = 0;  ///< the pass or body scan; 0 for none
    /// The newest record of the load when the change was committed (set by the store): the
    /// load's figures then are those of its records up to it.
    std::int64_t through_estimate_id = 0;
    LoadRecord load;  ///< as it stood right after the change
    /// The load's records up to through_estimate_id, oldest first, with payloads (ListLoadEvents
    /// with with_records): what its figures then are made of.
    std::vector<EstimateRecord> records;
};

/// Which events a ListLoadEvents returns: oldest first after after_id, or (without) the newest
/// first.
struct LoadEventQuery {
    std::string container_id;  ///< "" for every container
    std::string haul_unit_id;  ///< "" for every haul unit
    std::optional<std::int64_t> after_id;
    int limit = 100;
    bool with_records = true;
};

/// The event of `load` (already changed) of `kind` at `time_us`; `container_id` for a pass or
/// body scan, else the load's body container.
LoadEventRecord LoadEventOf(const LoadRecord& load, int kind, std::int64_t time_us,
                            std::string container_id = {});

/// Which records a List returns.
struct RecordQuery {
    std::string container_id;     ///< "" for every container
    std::string registration_id;  ///< "" for every registration
    /// Newest first below this id (a page after the previous one), or - with after_id -
    /// oldest first above it (a watch catching up). Neither: the newest first.
    std::optional<std::int64_t> before_id;
    std::optional<std::int64_t> after_id;
    std::int64_t start_time_us = std::numeric_limits<std::int64_t>::min();  ///< inclusive
    std::int64_t end_time_us = std::numeric_limits<std::int64_t>::max();    ///< exclusive
    int limit = 100;
    bool with_payload = true;
};

/// How long records stay: each container keeps its newest max_per_container, none older
/// than max_age.
struct RetentionPolicy {
    std::int64_t max_per_container = 10000;
    std::chrono::seconds max_age = std::chrono::hours(24 * 90);
};

/// Estimate records in a database shared by every replica that uses it. Thread-safe. Errors:
/// Unavailable when the database cannot be reached or is busy beyond its timeout, DataLoss for
/// a damaged one, NotFound from Get.
class RecordStore {
  public:
    virtual ~RecordStore() = default;

    /// Commits `records` in one transaction and sets their ids (in vector order). When it
    /// returns OK the records are durable: they survive the process being killed, and (SQLite
    /// synchronous=FULL; PostgreSQL's fsync) the machine losing power. A record with a load
    /// joins it in the same transaction (CheckJoin, after ApplyIdleClose at its time, which is
    /// kept): one that may not is left out with `rejected` set, the others are kept.
    virtual absl::Status Append(std::vector<EstimateRecord>& records) = 0;

    virtual absl::StatusOr<EstimateRecord> Get(const std::string& container_id,
                                               std::int64_t id) = 0;

    virtual absl::StatusOr<std::vector<EstimateRecord>> List(const RecordQuery& query) = 0;

    /// Deletes what `policy` no longer keeps as of `now_us`: every record older than max_age
    /// (through the time index), and all but the newest max_per_container records of each
    /// container in `containers` - those that got records since the last prune, the only ones
    /// that can have grown past it (each through the (container, id) index) - or, with
    /// nullopt, of every container (a scan of the whole table: once, at start). Alerts and
    /// webhook deliveries older than max_age go too. The number of records deleted.
    virtual absl::StatusOr<std::int64_t> Prune(
        const RetentionPolicy& policy, std::int64_t now_us,
        const std::optional<std::vector<std::string>>& containers) = 0;

    /// Deletes every record and alert of `container_id` (DeleteContainer with purge_records);
    /// the number of records deleted.
    virtual absl::StatusOr<std::int64_t> DeleteContainer(const std::string& container_id) = 0;

    /// Creates `load` (sets its seq) and, in the same transaction, closes its haul unit's open
    /// load (kNewLoad, or kIdle when it was idle for idle_us by then). AlreadyExists when its
    /// id is taken.
    virtual absl::Status CreateLoad(LoadRecord& load, std::int64_t idle_us) = 0;
    /// NotFound when there is none.
    virtual absl::StatusOr<LoadRecord> GetLoad(const std::string& load_id) = 0;
    virtual absl::StatusOr<std::vector<LoadRecord>> ListLoads(const LoadQuery& query) = 0;
    /// Closes an open load (kExplicit at now_us, or kIdle when it was idle for idle_us by
    /// then); a closed one is returned as it is. When `revision` is set the load must be at
    /// it (Aborted otherwise). NotFound when there is none.
    virtual absl::StatusOr<LoadRecord> CloseLoad(const std::string& load_id, std::int64_t now_us,
                                                 std::int64_t idle_us,
                                                 std::optional<std::int64_t> revision) = 0;
    /// The production rollup's rows of `dimension` at `granularity_us` (see production.hpp)
    /// with a bucket in [start_us, end_us): every record the store kept since the rollup
    /// existed but a load's body scan, summed in the transaction that kept it. Each cell holds
    /// its key in the field of its dimension (container_id, haul_unit_id or material; none for
    /// the total). Retention does not prune production (it outlives the records); purging a
    /// container's records purges its part.
    virtual absl::StatusOr<std::vector<ProductionCell>> ProductionCells(
        std::int64_t start_us, std::int64_t end_us, int dimension, std::int64_t granularity_us) = 0;
    /// Every record of these loads (with payloads and their LoadLink), oldest first.
    virtual absl::StatusOr<std::vector<EstimateRecord>> LoadEstimates(
        const std::vector<std::string>& load_ids) = 0;

    /// Load events (see LoadEventQuery), with their ids. Every change of a load keeps its event
    /// in the change's transaction: CreateLoad (kCreated; kClosed for the haul unit's previous
    /// load), Append (kPassAdded, kBodyScanned; kClosed when the record finds its load idle),
    /// CloseLoad (kClosed when it closes one). Prune and DeleteContainer remove them as alerts.
    virtual absl::StatusOr<std::vector<LoadEventRecord>> ListLoadEvents(
        const LoadEventQuery& query) = 0;
    /// Alerts (see AlertQuery), with their ids.
    virtual absl::StatusOr<std::vector<AlertRecord>> ListAlerts(const AlertQuery& query) = 0;
    /// Loads whose close was not judged yet (JudgeLoad): closed ones, and open ones idle since
    /// before idle_before_us (ApplyIdleClose would close them), oldest first. Loads kept from
    /// before alerts existed count as judged.
    virtual absl::StatusOr<std::vector<std::string>> UnjudgedLoads(std::int64_t idle_before_us,
                                                                   int limit) = 0;
    /// Marks a load's close judged and, in the same transaction, keeps `alert` (setting its id)
    /// when there is one: once per load however many replicas judge it. Whether this call
    /// judged it (false: judged before, or no such load).
    virtual absl::StatusOr<bool> JudgeLoad(const std::string& load_id,
                                           std::optional<AlertRecord>& alert) = 0;

    /// A webhook's state (created at the newest alert when new: it takes alerts from then on),
    /// leased to `holder` until lease_until_us when free (no lease, or an expired one, at
    /// now_us) or already the holder's; none when another replica holds it.
    virtual absl::StatusOr<std::optional<WebhookState>> LeaseWebhook(
        const std::string& webhook_id, const std::string& holder, std::int64_t now_us,
        std::int64_t lease_until_us) = 0;
    /// Writes `state` (cursor, delivery state) and the attempt, if any (setting its id), when
    /// `holder` still holds the lease; Aborted when it lost it (another replica sends now).
    virtual absl::Status SaveWebhook(const std::string& holder, const WebhookState& state,
                                     DeliveryRecord* attempt) = 0;
    /// Gives up `holder`'s lease of the webhook (a replica shutting down), so that another takes
    /// it over at once instead of when it lapses; nothing when another holds it.
    virtual absl::Status ReleaseWebhook(const std::string& webhook_id,
                                        const std::string& holder) = 0;
    /// The state of each of these webhooks that has one, with its pending alerts.
    virtual absl::StatusOr<std::vector<WebhookState>> WebhookStates(
        const std::vector<std::string>& webhook_ids) = 0;
    /// The delivery log, newest first.
    virtual absl::StatusOr<std::vector<DeliveryRecord>> ListDeliveries(
        const DeliveryQuery& query) = 0;

    /// "sqlite" or "postgresql", for logs and metrics.
    virtual const char* kind() const = 0;
};

/// The store a --records-url names: "" for SQLite at <data_dir>/records.sqlite3,
/// "sqlite:<path>" for another file, "postgres://..." or "postgresql://..." (libpq's URI) for
/// PostgreSQL. Creates the schema when missing. InvalidArgument for another scheme;
/// Unavailable (with the reason, the password left out) when it cannot be opened.
absl::StatusOr<std::unique_ptr<RecordStore>> OpenRecordStore(const std::string& url,
                                                             const std::filesystem::path& data_dir);

/// PostgreSQL at `url` (libpq's URI; the schema is created when missing).
absl::StatusOr<std::unique_ptr<RecordStore>> OpenPostgresRecordStore(const std::string& url);

/// `url` with any password replaced by ***.
std::string RedactedUrl(const std::string& url);

/// SQLite in `path` (WAL, synchronous=FULL, busy timeout 5 s: several processes of one machine
/// may share it; not over a network file system).
absl::StatusOr<std::unique_ptr<RecordStore>> OpenSqliteRecordStore(
    const std::filesystem::path& path);

}  // namespace soilvol::server
