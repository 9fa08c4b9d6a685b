#pragma once

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "server/records/record_store.hpp"

namespace soilvol::server {

/// Writes estimate records through one thread in batches (group commit): each caller hears
/// of the commit of the batch its record joined, so an answered estimate's record is
/// durable, while concurrent estimates share one transaction (and one fsync). Callers need
/// not wait for it on their own thread (RecordAsync): a worker goes on computing while the
/// commit it needs for its answer is on disk's time. Applies the retention policy now and
/// then, and wakes the watchers of this process after each commit.
class EstimateRecorder {
  public:
    struct Config {
        RetentionPolicy retention;
        std::size_t max_batch = 256;
        /// Records queued before RecordAsync makes its caller wait (a store slower than the
        /// estimates pushes back on the workers instead of growing the queue).
        std::size_t max_queued = 1024;
        std::chrono::seconds prune_every{60};
    };

    EstimateRecorder(RecordStore& store, Config config);
    /// Commits what is queued, then stops.
    ~EstimateRecorder();
    EstimateRecorder(const EstimateRecorder&) = delete;
    EstimateRecorder& operator=(const EstimateRecorder&) = delete;

    using Committed = std::function<void(absl::StatusOr<std::int64_t>)>;

    /// Queues `record`; `committed` gets its id once its batch is committed, or the store's
    /// error, or why the store left it out (EstimateRecord::rejected), on the recorder's thread
    /// (keep it short: the next batch waits for it). Waits only while max_queued records are
    /// queued. After the recorder stopped, `committed` gets UNAVAILABLE at once.
    void RecordAsync(EstimateRecord record, Committed committed);
    /// Queues `record` and waits until its batch is committed: its id, or the store's error.
    absl::StatusOr<std::int64_t> Record(EstimateRecord record);
    /// Waits until every record queued so far is committed and its caller told.
    void Flush();

    /// Blocks until this process commits a record with an id above `seen`, or `timeout`
    /// passes; the newest id it committed.
    std::int64_t WaitForNewer(std::int64_t seen, std::chrono::milliseconds timeout);
    /// Returns every WaitForNewer now (a feed shutting down).
    void WakeWaiters();

    RecordStore& store() const { return store_; }

    struct Stats {
        std::uint64_t records = 0, batches = 0, failures = 0, pruned = 0;
        std::size_t queued = 0;  ///< waiting for their commit now
        /// Alerts committed with the records (an estimate's, a run of refusals'), by kind.
        std::array<std::uint64_t, 6> alerts{};
    };
    Stats stats() const;

  private:
    struct Pending {
        EstimateRecord record;
        Committed committed;
    };
    void Run();
    /// Appends `batch` in one transaction and tells each caller (recorder thread, unlocked).
    void Commit(std::vector<Pending>& batch);
    /// Applies the retention policy to every container, or to those in touched_.
    void Prune(bool every_container);

    RecordStore& store_;
    const Config config_;
    mutable std::mutex mutex_;
    std::condition_variable work_;
    std::condition_variable committed_;  // a batch committed (watchers, Flush)
    std::condition_variable room_;       // the queue has room again
    std::deque<Pending> queue_;
    bool stopping_ = false;
    std::int64_t newest_ = 0;
    // Records queued, through their commit (failed or not), and with their caller told.
    std::uint64_t queued_total_ = 0, committed_total_ = 0, answered_total_ = 0;
    std::uint64_t wakes_ = 0;
    Stats stats_;
    std::chrono::steady_clock::time_point last_prune_;  // recorder thread only, as touched_
    std::set<std::string> touched_;  ///< containers recorded to since the last prune
    std::thread thread_;
};

}  // namespace soilvol::server
