#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <future>
#include <mutex>
#include <thread>

#include "server/records/record_store.hpp"

namespace soilvol::server {

/// Writes estimate records through one thread in batches (group commit): each caller waits
/// for the commit of the batch its record joined, so an answered estimate's record is
/// durable, while concurrent estimates share one transaction (and one fsync). Applies the
/// retention policy now and then, and wakes the watchers of this process after each commit.
class EstimateRecorder {
  public:
    struct Config {
        RetentionPolicy retention;
        std::size_t max_batch = 256;
        std::chrono::seconds prune_every{60};
    };

    EstimateRecorder(RecordStore& store, Config config);
    /// Commits what is queued, then stops.
    ~EstimateRecorder();
    EstimateRecorder(const EstimateRecorder&) = delete;
    EstimateRecorder& operator=(const EstimateRecorder&) = delete;

    /// Queues `record` and waits until its batch is committed: its id, or the store's error.
    absl::StatusOr<std::int64_t> Record(EstimateRecord record);

    /// Blocks until this process commits a record with an id above `seen`, or `timeout`
    /// passes; the newest id it committed.
    std::int64_t WaitForNewer(std::int64_t seen, std::chrono::milliseconds timeout);
    /// Returns every WaitForNewer now (a feed shutting down).
    void WakeWaiters();

    RecordStore& store() const { return store_; }

    struct Stats {
        std::uint64_t records = 0, batches = 0, failures = 0, pruned = 0;
    };
    Stats stats() const;

  private:
    struct Pending {
        EstimateRecord record;
        std::promise<absl::StatusOr<std::int64_t>> done;
    };
    void Run();
    void Prune();

    RecordStore& store_;
    const Config config_;
    mutable std::mutex mutex_;
    std::condition_variable work_;
    std::condition_variable committed_;
    std::deque<Pending> queue_;
    bool stopping_ = false;
    std::int64_t newest_ = 0;
    std::uint64_t wakes_ = 0;
    Stats stats_;
    std::chrono::steady_clock::time_point last_prune_;
    std::thread thread_;
};

}  // namespace soilvol::server
