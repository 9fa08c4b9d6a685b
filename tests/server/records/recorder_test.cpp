#include "server/records/recorder.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <thread>

#include "test_databases.hpp"

namespace soilvol::server {
namespace {

class RecorderTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RecorderTest, ConcurrentRecordsShareBatchesAndEachGetsItsId) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    EstimateRecorder recorder(*store, {});
    constexpr int kThreads = 8, kEach = 40;
    std::vector<std::vector<std::int64_t>> ids(kThreads);
    std::vector<std::thread> threads;
    for (int t = 0; t < kThreads; ++t) {
        threads.emplace_back([&, t] {
            for (int i = 0; i < kEach; ++i) {
                EstimateRecord record;
                record.container_id = "c" + std::to_string(t);
                record.create_time_us = i;
                record.payload = std::to_string(t * 1000 + i);
                const absl::StatusOr<std::int64_t> id = recorder.Record(record);
                ASSERT_TRUE(id.ok()) << id.status();
                ids[t].push_back(*id);
            }
        });
    }
    for (std::thread& thread : threads) thread.join();
    std::set<std::int64_t> unique;
    for (int t = 0; t < kThreads; ++t) {
        EXPECT_TRUE(std::is_sorted(ids[t].begin(), ids[t].end()));
        unique.insert(ids[t].begin(), ids[t].end());
        // Each id holds the record its caller gave.
        const auto got = store->Get("c" + std::to_string(t), ids[t][kEach / 2]);
        ASSERT_TRUE(got.ok());
        EXPECT_EQ(got->payload, std::to_string(t * 1000 + kEach / 2));
    }
    EXPECT_EQ(unique.size(), static_cast<std::size_t>(kThreads * kEach));
    const EstimateRecorder::Stats stats = recorder.stats();
    EXPECT_EQ(stats.records, static_cast<std::uint64_t>(kThreads * kEach));
    EXPECT_LE(stats.batches, stats.records);
}

TEST_P(RecorderTest, WatchersWakeOnACommit) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    EstimateRecorder recorder(*store, {});
    EXPECT_EQ(recorder.WaitForNewer(0, std::chrono::milliseconds(10)), 0);
    std::int64_t woke = 0;
    std::thread watcher([&] { woke = recorder.WaitForNewer(0, std::chrono::seconds(30)); });
    EstimateRecord record;
    record.container_id = "c";
    const absl::StatusOr<std::int64_t> id = recorder.Record(record);
    watcher.join();
    ASSERT_TRUE(id.ok());
    EXPECT_EQ(woke, *id);
}

TEST_P(RecorderTest, AsyncCallersHearOfTheirCommitWithoutWaitingForIt) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    EstimateRecorder::Config config;
    config.max_queued = 4;  // more records than this: the callers are pushed back, not refused
    EstimateRecorder recorder(*store, config);
    constexpr int kRecords = 50;
    std::mutex mutex;
    std::vector<std::int64_t> ids;
    std::set<std::thread::id> answered_on;
    const std::thread::id caller = std::this_thread::get_id();
    for (int i = 0; i < kRecords; ++i) {
        EstimateRecord record;
        record.container_id = "c";
        record.payload = std::to_string(i);
        recorder.RecordAsync(record, [&, i](absl::StatusOr<std::int64_t> id) {
            ASSERT_TRUE(id.ok()) << id.status();
            std::lock_guard<std::mutex> lock(mutex);
            ids.push_back(*id);
            answered_on.insert(std::this_thread::get_id());
            // The id holds this caller's record, already committed.
            const auto got = store->Get("c", *id);
            ASSERT_TRUE(got.ok()) << got.status();
            EXPECT_EQ(got->payload, std::to_string(i));
        });
    }
    recorder.Flush();  // every record queued above is committed and its caller told
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(ids.size(), static_cast<std::size_t>(kRecords));
    EXPECT_TRUE(std::is_sorted(ids.begin(), ids.end()));  // in the order they were queued
    EXPECT_EQ(answered_on.count(caller), 0u);             // on the recorder's thread
    EXPECT_EQ(recorder.stats().records, static_cast<std::uint64_t>(kRecords));
}

TEST_P(RecorderTest, RetentionAppliesAsRecordsArrive) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    EstimateRecorder::Config config;
    config.retention.max_per_container = 2;
    config.prune_every = std::chrono::seconds(0);  // after every batch
    EstimateRecorder recorder(*store, config);
    for (int i = 0; i < 5; ++i) {
        EstimateRecord record;
        record.container_id = "c";
        record.create_time_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                    std::chrono::system_clock::now().time_since_epoch())
                                    .count();
        ASSERT_TRUE(recorder.Record(record).ok());
    }
    RecordQuery query;
    query.container_id = "c";
    EXPECT_LE(store->List(query)->size(), 3u);  // the last batch may await its prune
    EXPECT_GE(recorder.stats().pruned, 2u);
}

/// A database that is down: every commit fails.
class DownStore final : public RecordStore {
  public:
    absl::Status Append(std::vector<EstimateRecord>&) override {
        ++appends;
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<EstimateRecord> Get(const std::string&, std::int64_t) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<EstimateRecord>> List(const RecordQuery&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::int64_t> Prune(const RetentionPolicy&, std::int64_t,
                                       const std::optional<std::vector<std::string>>&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::int64_t> DeleteContainer(const std::string&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::Status CreateLoad(LoadRecord&, std::int64_t) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<LoadRecord> GetLoad(const std::string&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<LoadRecord>> ListLoads(const LoadQuery&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<LoadRecord> CloseLoad(const std::string&, std::int64_t, std::int64_t,
                                         std::optional<std::int64_t>) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<ProductionCell>> ProductionCells(std::int64_t, std::int64_t, int,
                                                                std::int64_t) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<EstimateRecord>> LoadEstimates(
        const std::vector<std::string>&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<LoadEventRecord>> ListLoadEvents(const LoadEventQuery&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<AlertRecord>> ListAlerts(const AlertQuery&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<std::string>> UnjudgedLoads(std::int64_t, int) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<bool> JudgeLoad(const std::string&, std::optional<AlertRecord>&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::optional<WebhookState>> LeaseWebhook(const std::string&, const std::string&,
                                                             std::int64_t, std::int64_t) override {
        return absl::UnavailableError("connection refused");
    }
    absl::Status SaveWebhook(const std::string&, const WebhookState&, DeliveryRecord*) override {
        return absl::UnavailableError("connection refused");
    }
    absl::Status ReleaseWebhook(const std::string&, const std::string&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<WebhookState>> WebhookStates(
        const std::vector<std::string>&) override {
        return absl::UnavailableError("connection refused");
    }
    absl::StatusOr<std::vector<DeliveryRecord>> ListDeliveries(const DeliveryQuery&) override {
        return absl::UnavailableError("connection refused");
    }
    const char* kind() const override { return "down"; }
    std::atomic<int> appends{0};
};

TEST(Recorder, AFailedCommitReachesEveryCallerWithTheStoresError) {
    DownStore store;
    EstimateRecorder recorder(store, {});
    constexpr int kRecords = 20;
    std::atomic<int> failed{0};
    for (int i = 0; i < kRecords; ++i) {
        recorder.RecordAsync({}, [&](absl::StatusOr<std::int64_t> id) {
            EXPECT_EQ(id.status().code(), absl::StatusCode::kUnavailable);
            EXPECT_EQ(id.status().message(), "connection refused");
            ++failed;
        });
    }
    recorder.Flush();
    EXPECT_EQ(failed, kRecords);
    EXPECT_EQ(recorder.stats().failures, static_cast<std::uint64_t>(kRecords));
    EXPECT_EQ(recorder.stats().records, 0u);
    EXPECT_GE(store.appends, 1);
    EXPECT_LE(store.appends, kRecords);
}

INSTANTIATE_TEST_SUITE_P(Backends, RecorderTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
