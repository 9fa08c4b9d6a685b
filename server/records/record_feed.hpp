#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "server/records/recorder.hpp"

namespace soilvol::server {

/// How a RecordFeed polls, beats and bounds its watches.
struct FeedConfig {
    std::chrono::milliseconds poll{250};
    /// A watch that got nothing for this long gets a heartbeat (Deliver(nullptr)): SSE
    /// sends a comment, and a departed client is noticed.
    std::chrono::milliseconds heartbeat{1'000};
    /// Rounds with new rows start at most this often: rows committed within it after a round
    /// wait for the next, and go to each watch together (its stream writes them at once).
    std::chrono::milliseconds coalesce{0};
    std::size_t max_watches = 2048;  ///< --max-watches
    int batch = 200;                 ///< records read per query
    /// The watches of every feed given the same counter, which max_watches bounds together;
    /// null: this feed's alone.
    std::shared_ptr<std::atomic<std::size_t>> in_use = nullptr;
};

/// Live rows for watchers (WatchEstimates, WatchAlerts and WatchLoads, their SSE routes): one
/// thread reads what is new - at once after this process commits, and every poll interval for what
/// other replicas committed - and hands each row to the watches whose container it matches, in id
/// order. A watch may start after a last-seen id: it first catches up from the store, so a
/// reconnecting client loses nothing (ids increase in commit order, see RecordStore). Row is
/// EstimateRecord, AlertRecord or LoadEventRecord (each has an id and a container_id).
template <typename Row>
class RecordFeed {
  public:
    /// Where rows come from: those of a container ("" for all) after an id, oldest first, at
    /// most `limit`; and the newest id (none when the store cannot say now).
    struct Source {
        std::function<absl::StatusOr<std::vector<Row>>(const std::string& container_id,
                                                       std::int64_t after_id, int limit)>
            after;
        std::function<std::optional<std::int64_t>()> newest;
    };
    using Config = FeedConfig;
    /// Takes a row, or null for a heartbeat; false ends the watch (its client is gone or too
    /// slow).
    using Deliver = std::function<bool(const Row*)>;
    /// Called once when the feed ends a watch: Unavailable at shutdown, the store's error, or
    /// ResourceExhausted for a watch whose Deliver refused a record.
    using Ended = std::function<void(const absl::Status&)>;
    struct Spec {
        std::string container_id;              ///< "" for every container
        std::optional<std::int64_t> after_id;  ///< resume after it; none: from now on
        /// Rows of the container it also takes (null: all), e.g. one haul unit's.
        std::function<bool(const Row&)> match = nullptr;
    };
    class Watch;

    /// Wakes when `recorder` commits; reads from `source`.
    RecordFeed(EstimateRecorder& recorder, Source source, Config config);
    /// Ends every watch (Unavailable) and stops the thread.
    ~RecordFeed();
    RecordFeed(const RecordFeed&) = delete;
    RecordFeed& operator=(const RecordFeed&) = delete;

    /// A new watch; ResourceExhausted beyond max_watches (of every feed sharing in_use). `deliver`
    /// and `ended` run on the feed's thread.
    absl::StatusOr<std::shared_ptr<Watch>> Start(Spec spec, Deliver deliver, Ended ended);
    /// Ends `watch` without calling its `ended` (its client left). After it returns, the
    /// watch's callbacks are not called again.
    void Stop(const std::shared_ptr<Watch>& watch);

    std::size_t watches() const;

    /// Ends every watch (Unavailable) and refuses new ones; the destructor does it too.
    void Shutdown();

  private:
    /// One round: what is new since the last, every container at once, to every watch
    /// (each caught up from the store first when it is behind), heartbeats when due.
    void DeliverNew(const std::vector<std::shared_ptr<Watch>>& watches);
    void Run();
    /// Hands `watch` what it is owed up to `upto`: false when it ended.
    bool CatchUp(Watch& watch, std::int64_t upto);
    /// newest_ moved up to the newest id in the store (one index lookup).
    void ReadNewestId();
    void End(const std::shared_ptr<Watch>& watch, const absl::Status& status);
    /// Removes `watch` from watches_ (under mutex_), freeing its place in in_use_.
    void Forget(const std::shared_ptr<Watch>& watch);

    EstimateRecorder& recorder_;
    const Source source_;
    const Config config_;
    const std::shared_ptr<std::atomic<std::size_t>> in_use_;
    mutable std::mutex mutex_;
    std::vector<std::shared_ptr<Watch>> watches_;
    bool stopping_ = false;
    std::int64_t newest_ = 0;  ///< every record up to it was handed out (feed thread only)
    std::thread thread_;
};

using EstimateFeed = RecordFeed<EstimateRecord>;
using AlertFeed = RecordFeed<AlertRecord>;
using LoadEventFeed = RecordFeed<LoadEventRecord>;
extern template class RecordFeed<EstimateRecord>;
extern template class RecordFeed<AlertRecord>;
extern template class RecordFeed<LoadEventRecord>;

/// The feeds' sources over a store: its estimate records (without payloads for the newest id),
/// its alerts, and its load events.
EstimateFeed::Source EstimateSource(RecordStore& store);
AlertFeed::Source AlertSource(RecordStore& store);
LoadEventFeed::Source LoadEventSource(RecordStore& store);

}  // namespace soilvol::server
