#include "server/records/record_feed.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <condition_variable>
#include <memory>

#include "test_databases.hpp"

namespace soilvol::server {
namespace {

using namespace std::chrono_literals;

/// What a watch received, for waiting on from the test thread.
struct Inbox {
    std::mutex mutex;
    std::condition_variable changed;
    std::vector<EstimateRecord> records;
    std::optional<absl::Status> ended;
    int heartbeats = 0;

    EstimateFeed::Deliver Deliver() {
        return [this](const EstimateRecord* record) {
            std::lock_guard<std::mutex> lock(mutex);
            if (record == nullptr) {
                ++heartbeats;
                return true;
            }
            records.push_back(*record);
            changed.notify_all();
            return true;
        };
    }
    EstimateFeed::Ended Ended() {
        return [this](const absl::Status& status) {
            std::lock_guard<std::mutex> lock(mutex);
            ended = status;
            changed.notify_all();
        };
    }
    bool WaitFor(std::size_t count, std::chrono::milliseconds timeout) {
        std::unique_lock<std::mutex> lock(mutex);
        return changed.wait_for(lock, timeout, [&] { return records.size() >= count; });
    }
    std::vector<std::int64_t> Ids() {
        std::lock_guard<std::mutex> lock(mutex);
        std::vector<std::int64_t> ids;
        for (const EstimateRecord& r : records) ids.push_back(r.id);
        return ids;
    }
};

EstimateRecord Draft(const std::string& container) {
    EstimateRecord record;
    record.container_id = container;
    record.payload = "x";
    return record;
}

/// Each test's database (SQLite, or PostgreSQL where there is one), a store on it and its
/// recorder.
class EstimateFeedTest : public ::testing::TestWithParam<std::string> {
  protected:
    void SetUp() override {
        db_ = std::make_unique<TestDatabase>(GetParam());
        SOILVOL_NEED_DATABASE(*db_);
        store_ = db_->Open();
        ASSERT_NE(store_, nullptr);
        recorder_ = std::make_unique<EstimateRecorder>(*store_, EstimateRecorder::Config{});
    }

    std::unique_ptr<TestDatabase> db_;
    std::unique_ptr<RecordStore> store_;
    std::unique_ptr<EstimateRecorder> recorder_;
};

TEST_P(EstimateFeedTest, WatchesGetTheirContainersRecordsInOrderAtOnce) {
    ASSERT_TRUE(recorder_->Record(Draft("a")).ok());  // before the watch: not delivered
    Inbox a, every;                                   // before the feed: it outlives their watches
    EstimateFeed feed(*recorder_, EstimateSource(*store_), {});
    auto watch_a = feed.Start({"a", std::nullopt}, a.Deliver(), a.Ended());
    auto watch_all = feed.Start({"", std::nullopt}, every.Deliver(), every.Ended());
    ASSERT_TRUE(watch_a.ok() && watch_all.ok());
    std::this_thread::sleep_for(300ms);  // the feed places new watches at its next round
    std::vector<std::int64_t> ids_a;
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < 6; ++i) {
        const auto id = recorder_->Record(Draft(i % 2 == 0 ? "a" : "b"));
        ASSERT_TRUE(id.ok());
        if (i % 2 == 0) ids_a.push_back(*id);
    }
    ASSERT_TRUE(a.WaitFor(3, 5s));
    ASSERT_TRUE(every.WaitFor(6, 5s));
    // Local commits wake the feed: well within the 1 s the API promises.
    EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
    EXPECT_EQ(a.Ids(), ids_a);
    const std::vector<std::int64_t> all = every.Ids();
    EXPECT_EQ(all.size(), 6u);
    EXPECT_TRUE(std::is_sorted(all.begin(), all.end()));
    feed.Stop(*watch_a);
    EXPECT_EQ(feed.watches(), 1u);
}

TEST_P(EstimateFeedTest, ARoundHandsAWatchItsRowsTogetherThenTheNextWatch) {
    // So that a stream writes a round's rows at once, and a consumer that keeps the last
    // kFeedGroupRows rows it made makes each once for all its watches.
    std::mutex mutex;
    std::vector<std::pair<int, std::int64_t>> log;  // (watch, record id) in delivery order
    std::atomic<bool> held{false}, released{false};
    auto deliver = [&](int watch) {
        return [&, watch](const EstimateRecord* record) {
            if (record == nullptr) return true;
            {
                std::lock_guard<std::mutex> lock(mutex);
                log.emplace_back(watch, record->id);
            }
            // The first record holds the feed's round while two more are committed.
            if (watch == 1 && !held.exchange(true)) {
                for (int i = 0; i < 500 && !released; ++i) std::this_thread::sleep_for(10ms);
            }
            return true;
        };
    };
    EstimateFeed feed(*recorder_, EstimateSource(*store_), {});
    ASSERT_TRUE(feed.Start({"", std::nullopt}, deliver(1), [](const absl::Status&) {}).ok());
    ASSERT_TRUE(feed.Start({"", std::nullopt}, deliver(2), [](const absl::Status&) {}).ok());
    std::this_thread::sleep_for(300ms);  // placed
    std::vector<std::int64_t> ids;
    ids.push_back(*recorder_->Record(Draft("a")));
    for (int i = 0; i < 500 && !held; ++i) std::this_thread::sleep_for(10ms);
    ASSERT_TRUE(held);
    ids.push_back(*recorder_->Record(Draft("b")));
    ids.push_back(*recorder_->Record(Draft("a")));
    released = true;
    const auto all_there = [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return log.size() >= 6;
    };
    for (int i = 0; i < 500 && !all_there(); ++i) std::this_thread::sleep_for(10ms);
    std::lock_guard<std::mutex> lock(mutex);
    const std::vector<std::pair<int, std::int64_t>> expected = {
        {1, ids[0]}, {2, ids[0]}, {1, ids[1]}, {1, ids[2]}, {2, ids[1]}, {2, ids[2]}};
    EXPECT_EQ(log, expected);
}

TEST_P(EstimateFeedTest, CommitsWithinTheCoalescingIntervalArriveTogether) {
    EstimateFeed::Config config;
    config.coalesce = 400ms;
    using Clock = std::chrono::steady_clock;
    std::mutex mutex;
    std::vector<Clock::time_point> arrived;
    EstimateFeed feed(*recorder_, EstimateSource(*store_), config);
    ASSERT_TRUE(feed.Start(
                        {"", std::nullopt},
                        [&](const EstimateRecord* record) {
                            std::lock_guard<std::mutex> lock(mutex);
                            if (record != nullptr) arrived.push_back(Clock::now());
                            return true;
                        },
                        [](const absl::Status&) {})
                    .ok());
    std::this_thread::sleep_for(300ms);  // placed
    const auto count = [&] {
        std::lock_guard<std::mutex> lock(mutex);
        return arrived.size();
    };
    const Clock::time_point first = Clock::now();
    ASSERT_TRUE(recorder_->Record(Draft("a")).ok());
    for (int i = 0; i < 500 && count() < 1; ++i) std::this_thread::sleep_for(1ms);
    ASSERT_TRUE(recorder_->Record(Draft("a")).ok());
    ASSERT_TRUE(recorder_->Record(Draft("b")).ok());
    for (int i = 0; i < 300 && count() < 3; ++i) std::this_thread::sleep_for(10ms);
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_EQ(arrived.size(), 3u);
    // The first after a quiet spell at once; the two behind it wait out the interval and
    // arrive in one round.
    EXPECT_LT(arrived[0] - first, 200ms);
    EXPECT_GE(arrived[1] - arrived[0], 300ms);
    EXPECT_LT(arrived[1] - arrived[0], 1s);
    EXPECT_LT(arrived[2] - arrived[1], 50ms);
}

TEST_P(EstimateFeedTest, QuietWatchesGetHeartbeats) {
    EstimateFeed::Config config;
    config.poll = 20ms;
    config.heartbeat = 100ms;
    Inbox inbox;
    EstimateFeed feed(*recorder_, EstimateSource(*store_), config);
    ASSERT_TRUE(feed.Start({"", std::nullopt}, inbox.Deliver(), inbox.Ended()).ok());
    std::this_thread::sleep_for(600ms);
    std::lock_guard<std::mutex> lock(inbox.mutex);
    EXPECT_GE(inbox.heartbeats, 3);
    EXPECT_LE(inbox.heartbeats, 7);
    EXPECT_TRUE(inbox.records.empty());
}

TEST_P(EstimateFeedTest, AResumedWatchCatchesUpThenGoesLiveAndSeesOtherReplicas) {
    auto replica = db_->Open();
    ASSERT_NE(replica, nullptr);
    std::vector<EstimateRecord> earlier;
    for (int i = 0; i < 450; ++i) earlier.push_back(Draft(i % 3 == 0 ? "c" : "d"));
    ASSERT_TRUE(store_->Append(earlier).ok());
    EstimateFeed::Config config;
    config.batch = 100;  // several catch-up pages
    Inbox inbox;
    EstimateFeed feed(*recorder_, EstimateSource(*store_), config);
    const std::int64_t resume = earlier[29].id;
    ASSERT_TRUE(feed.Start({"c", resume}, inbox.Deliver(), inbox.Ended()).ok());
    std::vector<std::int64_t> expected;
    for (const EstimateRecord& r : earlier) {
        if (r.id > resume && r.container_id == "c") expected.push_back(r.id);
    }
    ASSERT_TRUE(inbox.WaitFor(expected.size(), 10s));
    // Another replica writes straight to the database: seen by polling within a second.
    std::vector<EstimateRecord> theirs = {Draft("c")};
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(replica->Append(theirs).ok());
    expected.push_back(theirs[0].id);
    ASSERT_TRUE(inbox.WaitFor(expected.size(), 5s));
    EXPECT_LT(std::chrono::steady_clock::now() - start, 1s);
    EXPECT_EQ(inbox.Ids(), expected);
}

TEST_P(EstimateFeedTest, SlowWatchesEndAndShutdownEndsTheRest) {
    Inbox slow_ended, rest;
    {
        EstimateFeed::Config config;
        config.max_watches = 2;
        EstimateFeed feed(*recorder_, EstimateSource(*store_), config);
        ASSERT_TRUE(
            feed.Start(
                    {"", 0}, [](const EstimateRecord*) { return false; }, slow_ended.Ended())
                .ok());
        ASSERT_TRUE(feed.Start({"", std::nullopt}, rest.Deliver(), rest.Ended()).ok());
        EXPECT_TRUE(absl::IsResourceExhausted(
            feed.Start({"", std::nullopt}, rest.Deliver(), rest.Ended()).status()));
        ASSERT_TRUE(recorder_->Record(Draft("a")).ok());
        ASSERT_TRUE(rest.WaitFor(1, 5s));
        std::unique_lock<std::mutex> lock(slow_ended.mutex);
        ASSERT_TRUE(
            slow_ended.changed.wait_for(lock, 5s, [&] { return slow_ended.ended.has_value(); }));
        EXPECT_TRUE(absl::IsResourceExhausted(*slow_ended.ended));
    }
    ASSERT_TRUE(rest.ended.has_value());
    EXPECT_TRUE(absl::IsUnavailable(*rest.ended));
}

TEST_P(EstimateFeedTest, ALoadWatchOfOneHaulUnitCatchesUpThenGetsItsNewEventsInOrder) {
    auto create = [this](const std::string& id, const std::string& haul_unit) {
        LoadRecord load;
        load.load_id = id;
        load.haul_unit_id = haul_unit;
        load.payload = "x";
        return store_->CreateLoad(load, 0);
    };
    ASSERT_TRUE(create("l-1", "truck-1").ok());
    ASSERT_TRUE(create("l-2", "truck-2").ok());
    ASSERT_TRUE(create("l-3", "truck-1").ok());  // closes l-1: two events of truck-1
    std::mutex mutex;
    std::vector<std::string> seen;  // "<load> <kind>"
    LoadEventFeed feed(*recorder_, LoadEventSource(*store_), {});
    LoadEventFeed::Spec spec;
    spec.after_id = 0;
    spec.match = [](const LoadEventRecord& row) { return row.load.haul_unit_id == "truck-1"; };
    auto watch = feed.Start(
        spec,
        [&](const LoadEventRecord* row) {
            std::lock_guard<std::mutex> lock(mutex);
            if (row != nullptr) seen.push_back(row->load.load_id + " " + std::to_string(row->kind));
            return true;
        },
        [](const absl::Status&) {});
    ASSERT_TRUE(watch.ok());
    ASSERT_TRUE(create("l-4", "truck-2").ok());
    ASSERT_TRUE(store_->CloseLoad("l-3", 1, 0, std::nullopt).ok());
    const std::vector<std::string> expected = {"l-1 1", "l-1 4", "l-3 1", "l-3 4"};
    for (int i = 0; i < 100; ++i) {
        {
            std::lock_guard<std::mutex> lock(mutex);
            if (seen.size() >= expected.size()) break;
        }
        std::this_thread::sleep_for(50ms);
    }
    feed.Stop(*watch);
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(seen, expected);
}

TEST_P(EstimateFeedTest, FeedsSharingACounterShareOneLimit) {
    FeedConfig config;
    config.max_watches = 2;
    config.in_use = std::make_shared<std::atomic<std::size_t>>(0);
    Inbox inbox;
    EstimateFeed estimates(*recorder_, EstimateSource(*store_), config);
    LoadEventFeed loads(*recorder_, LoadEventSource(*store_), config);
    auto quiet = [](const LoadEventRecord*) { return true; };
    auto ended = [](const absl::Status&) {};
    auto first = estimates.Start({"", std::nullopt}, inbox.Deliver(), inbox.Ended());
    auto second = loads.Start({}, quiet, ended);
    ASSERT_TRUE(first.ok() && second.ok());
    EXPECT_TRUE(absl::IsResourceExhausted(loads.Start({}, quiet, ended).status()));
    EXPECT_TRUE(absl::IsResourceExhausted(
        estimates.Start({"", std::nullopt}, inbox.Deliver(), inbox.Ended()).status()));
    estimates.Stop(*first);
    estimates.Stop(*first);  // twice: freed once
    auto third = loads.Start({}, quiet, ended);
    ASSERT_TRUE(third.ok());
    EXPECT_EQ(*config.in_use, 2u);
    EXPECT_TRUE(absl::IsResourceExhausted(loads.Start({}, quiet, ended).status()));
    loads.Shutdown();  // its two watches end: their places come back
    EXPECT_EQ(*config.in_use, 0u);
}

INSTANTIATE_TEST_SUITE_P(Backends, EstimateFeedTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
