#include "server/records/recorder.hpp"

#include <future>
#include <vector>

namespace soilvol::server {

EstimateRecorder::EstimateRecorder(RecordStore& store, Config config)
    : store_(store), config_(config), last_prune_(std::chrono::steady_clock::now()) {
    Prune(true);  // every container once: the policy may have changed since the last run
    thread_ = std::thread([this] { Run(); });
}

EstimateRecorder::~EstimateRecorder() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    work_.notify_all();
    room_.notify_all();
    thread_.join();
}

void EstimateRecorder::RecordAsync(EstimateRecord record, Committed committed) {
    {
        std::unique_lock<std::mutex> lock(mutex_);
        room_.wait(lock, [&] { return stopping_ || queue_.size() < config_.max_queued; });
        if (!stopping_) {
            queue_.push_back({std::move(record), std::move(committed)});
            ++queued_total_;
            committed = nullptr;
        }
    }
    if (committed) {
        committed(absl::UnavailableError("records: the server is shutting down"));
        return;
    }
    work_.notify_one();
}

absl::StatusOr<std::int64_t> EstimateRecorder::Record(EstimateRecord record) {
    std::promise<absl::StatusOr<std::int64_t>> done;
    std::future<absl::StatusOr<std::int64_t>> answer = done.get_future();
    RecordAsync(std::move(record),
                [&done](absl::StatusOr<std::int64_t> id) { done.set_value(std::move(id)); });
    return answer.get();
}

void EstimateRecorder::Flush() {
    std::unique_lock<std::mutex> lock(mutex_);
    const std::uint64_t target = queued_total_;
    committed_.wait(lock, [&] { return answered_total_ >= target; });
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
    Stats now = stats_;
    now.queued = static_cast<std::size_t>(queued_total_ - committed_total_);
    return now;
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
            Prune(false);
            lock.lock();
            continue;
        }
        std::vector<Pending> batch;
        while (!queue_.empty() && batch.size() < config_.max_batch) {
            batch.push_back(std::move(queue_.front()));
            queue_.pop_front();
        }
        lock.unlock();
        room_.notify_all();
        Commit(batch);
        if (std::chrono::steady_clock::now() - last_prune_ >= config_.prune_every) Prune(false);
        lock.lock();
    }
}

namespace {

/// The alerts Append kept for `record` (those it kept have ids).
void CountAlerts(const EstimateRecord& record, std::array<std::uint64_t, 6>& by_kind) {
    const auto count = [&by_kind](const AlertRecord& alert) {
        if (alert.id != 0 && alert.kind > 0 && alert.kind < static_cast<int>(by_kind.size())) {
            ++by_kind[static_cast<std::size_t>(alert.kind)];
        }
    };
    for (const AlertRecord& alert : record.alerts) count(alert);
    if (record.refusal) count(record.refusal->alert);
}

}  // namespace

void EstimateRecorder::Commit(std::vector<Pending>& batch) {
    std::vector<EstimateRecord> records;
    records.reserve(batch.size());
    for (Pending& pending : batch) records.push_back(std::move(pending.record));
    const absl::Status status = store_.Append(records);
    {
        // Counted before any caller returns, so that what a caller sees includes its own.
        std::lock_guard<std::mutex> counted(mutex_);
        ++stats_.batches;
        committed_total_ += records.size();
        if (status.ok()) {
            for (const EstimateRecord& record : records) {
                CountAlerts(record, stats_.alerts);
                if (record.id == 0) continue;  // rejected by its load, or a refusal
                ++stats_.records;
                newest_ = std::max(newest_, record.id);
            }
        } else {
            stats_.failures += records.size();
        }
    }
    committed_.notify_all();  // watchers first: the record is there for them to read
    for (std::size_t i = 0; i < batch.size(); ++i) {
        if (!status.ok()) {
            batch[i].committed(status);
        } else if (!records[i].rejected.ok()) {
            batch[i].committed(records[i].rejected);
        } else {
            batch[i].committed(records[i].id);
        }
    }
    {
        std::lock_guard<std::mutex> answered(mutex_);
        answered_total_ += batch.size();
    }
    committed_.notify_all();
    if (status.ok()) {
        for (const EstimateRecord& record : records) {
            if (record.id != 0) touched_.insert(record.container_id);
        }
    }
}

void EstimateRecorder::Prune(bool every_container) {
    last_prune_ = std::chrono::steady_clock::now();
    std::optional<std::vector<std::string>> containers;
    if (!every_container) containers.emplace(touched_.begin(), touched_.end());
    const std::int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                    std::chrono::system_clock::now().time_since_epoch())
                                    .count();
    const absl::StatusOr<std::int64_t> pruned = store_.Prune(config_.retention, now_us, containers);
    if (pruned.ok()) touched_.clear();  // else: again next time
    std::lock_guard<std::mutex> lock(mutex_);
    if (pruned.ok()) stats_.pruned += static_cast<std::uint64_t>(*pruned);
}

}  // namespace soilvol::server
