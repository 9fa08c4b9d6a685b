#include "server/records/recorder.hpp"

#include <vector>

namespace soilvol::server {

EstimateRecorder::EstimateRecorder(RecordStore& store, Config config)
    : store_(store), config_(config), last_prune_(std::chrono::steady_clock::now()) {
    Prune();
    thread_ = std::thread([this] { Run(); });
}

EstimateRecorder::~EstimateRecorder() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    work_.notify_all();
    thread_.join();
}

absl::StatusOr<std::int64_t> EstimateRecorder::Record(EstimateRecord record) {
    std::future<absl::StatusOr<std::int64_t>> done;
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stopping_) return absl::UnavailableError("records: the server is shutting down");
        queue_.push_back({std::move(record), {}});
        done = queue_.back().done.get_future();
    }
    work_.notify_one();
    return done.get();
}

std::int64_t EstimateRecorder::WaitForNewer(std::int64_t seen, std::chrono::milliseconds timeout) {
    std::unique_lock<std::mutex> lock(mutex_);
    const std::uint64_t wakes = wakes_;
    committed_.wait_for(lock, timeout,
                        [&] { return newest_ > seen || stopping_ || wakes_ != wakes; });
    return newest_;
}

void EstimateRecorder::WakeWaiters() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        ++wakes_;
    }
    committed_.notify_all();
}

EstimateRecorder::Stats EstimateRecorder::stats() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
}

void EstimateRecorder::Run() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (true) {
        const auto idle =
            std::max<std::chrono::seconds>(config_.prune_every, std::chrono::seconds(1));
        work_.wait_for(lock, idle, [&] { return stopping_ || !queue_.empty(); });
        if (queue_.empty()) {
            if (stopping_) return;
            lock.unlock();
            Prune();
            lock.lock();
            continue;
        }
        std::vector<Pending> batch;
        while (!queue_.empty() && batch.size() < config_.max_batch) {
            batch.push_back(std::move(queue_.front()));
            queue_.pop_front();
        }
        lock.unlock();
        std::vector<EstimateRecord> records;
        records.reserve(batch.size());
        for (Pending& pending : batch) records.push_back(std::move(pending.record));
        const absl::Status status = store_.Append(records);
        {
            // Counted before any caller returns, so that what a caller sees includes its own.
            std::lock_guard<std::mutex> counted(mutex_);
            ++stats_.batches;
            if (status.ok()) {
                stats_.records += records.size();
                newest_ = std::max(newest_, records.back().id);
            } else {
                stats_.failures += records.size();
            }
        }
        committed_.notify_all();
        for (std::size_t i = 0; i < batch.size(); ++i) {
            if (status.ok()) {
                batch[i].done.set_value(records[i].id);
            } else {
                batch[i].done.set_value(status);
            }
        }
        if (std::chrono::steady_clock::now() - last_prune_ >= config_.prune_every) Prune();
        lock.lock();
    }
}

void EstimateRecorder::Prune() {
    last_prune_ = std::chrono::steady_clock::now();
    const std::int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                    std::chrono::system_clock::now().time_since_epoch())
                                    .count();
    const absl::StatusOr<std::int64_t> pruned = store_.Prune(config_.retention, now_us);
    std::lock_guard<std::mutex> lock(mutex_);
    if (pruned.ok()) stats_.pruned += static_cast<std::uint64_t>(*pruned);
}

}  // namespace soilvol::server
