#include "server/records/record_feed.hpp"

#include <pthread.h>

#include <algorithm>
#include <type_traits>

#include "absl/strings/str_cat.h"
#include "server/base/recent_cache.hpp"

namespace soilvol::server {

template <typename Row>
class RecordFeed<Row>::Watch {
  public:
    Watch(Spec spec, Deliver deliver, Ended ended)
        : spec_(std::move(spec)), deliver_(std::move(deliver)), ended_(std::move(ended)) {}

    const Spec spec_;
    std::int64_t cursor_ = 0;  ///< every matching record up to it was delivered
    std::chrono::steady_clock::time_point last_sent_ = std::chrono::steady_clock::now();
    std::mutex call_mutex_;  ///< held while a callback runs, so Stop can wait it out
    bool live_ = true;       ///< under call_mutex_

    /// Delivers unless stopped; false when the watch is (now) over.
    /// `record` null: a heartbeat.
    bool Offer(const Row* record) {
        std::lock_guard<std::mutex> lock(call_mutex_);
        if (!live_) return false;
        if (record != nullptr &&
            ((!spec_.container_id.empty() && record->container_id != spec_.container_id) ||
             (spec_.match && !spec_.match(*record)))) {
            return true;
        }
        last_sent_ = std::chrono::steady_clock::now();
        if (deliver_(record)) return true;
        live_ = false;
        ended_(absl::ResourceExhaustedError(
            record != nullptr ? absl::StrCat("the watch fell behind at estimate ", record->id,
                                             "; reconnect after the last id received")
                              : std::string("the watcher is gone")));
        return false;
    }
    void Close(const absl::Status& status, bool notify) {
        std::lock_guard<std::mutex> lock(call_mutex_);
        if (!live_) return;
        live_ = false;
        if (notify) ended_(status);
    }
    bool live() {
        std::lock_guard<std::mutex> lock(call_mutex_);
        return live_;
    }

  private:
    Deliver deliver_;
    Ended ended_;
};

template <typename Row>
RecordFeed<Row>::RecordFeed(EstimateRecorder& recorder, Source source, Config config)
    : recorder_(recorder),
      source_(std::move(source)),
      config_(config),
      in_use_(config.in_use != nullptr ? config.in_use
                                       : std::make_shared<std::atomic<std::size_t>>(0)) {
    ReadNewestId();
    thread_ = std::thread([this] { Run(); });
}

template <typename Row>
void RecordFeed<Row>::ReadNewestId() {
    if (const std::optional<std::int64_t> newest = source_.newest()) {
        newest_ = std::max(newest_, *newest);
    }
}

template <typename Row>
RecordFeed<Row>::~RecordFeed() {
    Shutdown();
}

template <typename Row>
void RecordFeed<Row>::Shutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        if (stopping_) return;
        stopping_ = true;
    }
    recorder_.WakeWaiters();  // now, not at the end of its poll
    thread_.join();
}

template <typename Row>
absl::StatusOr<std::shared_ptr<typename RecordFeed<Row>::Watch>> RecordFeed<Row>::Start(
    Spec spec, Deliver deliver, Ended ended) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopping_) return absl::UnavailableError("the server is shutting down");
    std::size_t in_use = in_use_->load();
    do {
        if (in_use >= config_.max_watches) {
            return absl::ResourceExhaustedError(
                absl::StrCat("at most ", config_.max_watches, " watches at once"));
        }
    } while (!in_use_->compare_exchange_weak(in_use, in_use + 1));
    auto watch = std::make_shared<Watch>(std::move(spec), std::move(deliver), std::move(ended));
    // From now on unless told where to resume: the feed thread sets the cursor to the newest
    // id it has handed out (0 marks "not yet placed").
    watch->cursor_ = watch->spec_.after_id.value_or(-1);
    watches_.push_back(watch);
    return watch;
}

template <typename Row>
void RecordFeed<Row>::Stop(const std::shared_ptr<Watch>& watch) {
    watch->Close(absl::OkStatus(), false);
    std::lock_guard<std::mutex> lock(mutex_);
    Forget(watch);
}

template <typename Row>
void RecordFeed<Row>::Forget(const std::shared_ptr<Watch>& watch) {
    const auto gone = std::remove(watches_.begin(), watches_.end(), watch);
    *in_use_ -= static_cast<std::size_t>(watches_.end() - gone);
    watches_.erase(gone, watches_.end());
}

template <typename Row>
std::size_t RecordFeed<Row>::watches() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return watches_.size();
}

template <typename Row>
void RecordFeed<Row>::End(const std::shared_ptr<Watch>& watch, const absl::Status& status) {
    watch->Close(status, true);
    std::lock_guard<std::mutex> lock(mutex_);
    Forget(watch);
}

template <typename Row>
bool RecordFeed<Row>::CatchUp(Watch& watch, std::int64_t upto) {
    while (watch.cursor_ < upto) {
        absl::StatusOr<std::vector<Row>> rows =
            source_.after(watch.spec_.container_id, watch.cursor_, config_.batch);
        if (!rows.ok()) return true;  // the store is away: try again next round
        for (const Row& row : *rows) {
            if (row.id > upto) break;
            if (!watch.Offer(&row)) return false;
            watch.cursor_ = row.id;
        }
        if (static_cast<int>(rows->size()) < config_.batch || rows->back().id >= upto) {
            watch.cursor_ = upto;
        }
    }
    return true;
}

template <typename Row>
void RecordFeed<Row>::DeliverNew(const std::vector<std::shared_ptr<Watch>>& watches) {
    // What is new since the last round, every container at once.
    std::vector<Row> fresh;
    if (auto rows = source_.after("", newest_, config_.batch); rows.ok()) fresh = *std::move(rows);
    const std::int64_t before = newest_;
    if (!fresh.empty()) newest_ = fresh.back().id;
    std::vector<Watch*> open;
    for (const auto& watch : watches) {
        if (!watch->live()) continue;
        if (watch->cursor_ < 0) watch->cursor_ = before;  // placed: from now on
        // Behind (resumed from an old id): from the store first.
        if (CatchUp(*watch, before)) open.push_back(watch.get());
    }
    // Each group of rows to every watch in turn, the whole group to one watch before the next:
    // its stream writes them at once, and a consumer converts and renders each row of the
    // group once for all watches (kFeedGroupRows).
    for (std::size_t first = 0; first < fresh.size(); first += kFeedGroupRows) {
        const std::size_t end = std::min(fresh.size(), first + kFeedGroupRows);
        for (Watch* watch : open) {
            for (std::size_t i = first; i < end; ++i) {
                const Row& row = fresh[i];
                if (row.id > watch->cursor_ && watch->Offer(&row)) watch->cursor_ = row.id;
            }
        }
    }
    for (const auto& watch : watches) {
        if (watch->live() &&
            std::chrono::steady_clock::now() - watch->last_sent_ >= config_.heartbeat) {
            watch->Offer(nullptr);
        }
        if (!watch->live()) {
            End(watch, absl::OkStatus());
        } else {
            watch->cursor_ = std::max(watch->cursor_, newest_);
        }
    }
}

template <typename Row>
void RecordFeed<Row>::Run() {
    pthread_setname_np(pthread_self(), "soilvol-feed");  // top -H, perf, gdb
    std::int64_t seen_local = 0;
    std::chrono::steady_clock::time_point last_round;
    while (true) {
        const std::int64_t seen_before = seen_local;
        seen_local = recorder_.WaitForNewer(seen_local, config_.poll);
        // A commit soon after the last round waits out the coalescing interval, with what
        // else commits meanwhile (a burst of estimates: one write per watcher, not one each).
        if (seen_local > seen_before) {
            std::this_thread::sleep_until(last_round + config_.coalesce);
            last_round = std::chrono::steady_clock::now();
        }
        std::vector<std::shared_ptr<Watch>> watches;
        bool stopping = false;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            stopping = stopping_;
            if (stopping) {
                watches.swap(watches_);
                *in_use_ -= watches.size();
            } else {
                watches = watches_;
            }
        }
        if (stopping) {  // the callbacks run without the feed's lock: they may call Stop
            for (const auto& watch : watches) {
                watch->Close(absl::UnavailableError("the server is shutting down"), true);
            }
            return;
        }
        if (watches.empty()) {  // nobody to hand records to: only where "now" is
            if (seen_local > seen_before && std::is_same_v<Row, EstimateRecord>) {
                newest_ = std::max(newest_, seen_local);  // this process committed it
            } else {
                ReadNewestId();  // a poll: other replicas' records
            }
            continue;
        }
        DeliverNew(watches);
    }
}

template class RecordFeed<EstimateRecord>;
template class RecordFeed<AlertRecord>;
template class RecordFeed<LoadEventRecord>;

namespace {

/// A feed's source over a store's list of rows by Query (container_id, after_id, limit);
/// `newest` asks for the newest row.
template <typename Row, typename Query, typename List>
typename RecordFeed<Row>::Source ListSource(List list, Query newest) {
    typename RecordFeed<Row>::Source source;
    source.after = [list](const std::string& container_id, std::int64_t after_id, int limit) {
        Query query;
        query.container_id = container_id;
        query.after_id = after_id;
        query.limit = limit;
        return list(query);
    };
    newest.limit = 1;
    source.newest = [list, newest]() -> std::optional<std::int64_t> {
        absl::StatusOr<std::vector<Row>> rows = list(newest);
        if (!rows.ok()) return std::nullopt;
        return rows->empty() ? 0 : rows->front().id;
    };
    return source;
}

}  // namespace

EstimateFeed::Source EstimateSource(RecordStore& store) {
    RecordQuery newest;
    newest.with_payload = false;
    return ListSource<EstimateRecord>([&store](const RecordQuery& q) { return store.List(q); },
                                      newest);
}

AlertFeed::Source AlertSource(RecordStore& store) {
    return ListSource<AlertRecord>([&store](const AlertQuery& q) { return store.ListAlerts(q); },
                                   AlertQuery());
}

LoadEventFeed::Source LoadEventSource(RecordStore& store) {
    LoadEventQuery newest;
    newest.with_records = false;
    return ListSource<LoadEventRecord>(
        [&store](const LoadEventQuery& q) { return store.ListLoadEvents(q); }, newest);
}

}  // namespace soilvol::server
