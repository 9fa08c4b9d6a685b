#include <gtest/gtest.h>

#include <vector>

#include "load_fixtures.hpp"
#include "server/records/load_record.hpp"
#include "server/records/record_store.hpp"
#include "test_databases.hpp"

namespace soilvol::server {
namespace {

constexpr std::int64_t kMin = 60'000'000;

std::vector<LoadEventRecord> Events(RecordStore& store, LoadEventQuery query = {}) {
    query.after_id = query.after_id.value_or(0);
    query.limit = 1000;
    absl::StatusOr<std::vector<LoadEventRecord>> events = store.ListLoadEvents(query);
    EXPECT_TRUE(events.ok()) << events.status();
    return events.ok() ? *events : std::vector<LoadEventRecord>();
}

std::vector<int> KindsOf(const std::vector<LoadEventRecord>& events) {
    std::vector<int> kinds;
    for (const LoadEventRecord& event : events) kinds.push_back(event.kind);
    return kinds;
}

class LoadEventStoreTest : public ::testing::TestWithParam<std::string> {};

TEST_P(LoadEventStoreTest, EveryChangeOfALoadIsAnEventInCommitOrderWithItsStateThen) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    LoadRecord load = NewLoad("l-1", "truck-7", kMin);
    ASSERT_TRUE(store->CreateLoad(load, 0).ok());
    std::vector<EstimateRecord> passes = {Pass("l-1", 2 * kMin), Pass("l-1", 3 * kMin)};
    ASSERT_TRUE(store->Append(passes).ok());
    ASSERT_TRUE(store->CloseLoad("l-1", 4 * kMin, 0, std::nullopt).ok());
    ASSERT_TRUE(store->CloseLoad("l-1", 5 * kMin, 0, std::nullopt).ok());  // closed: no change
    std::vector<EstimateRecord> body = {Pass("l-1", 6 * kMin, LoadLink::kBodyScan)};
    ASSERT_TRUE(store->Append(body).ok());
    LoadRecord second = NewLoad("l-2", "truck-7", 7 * kMin);
    ASSERT_TRUE(store->CreateLoad(second, 0).ok());
    LoadRecord third = NewLoad("l-3", "truck-7", 8 * kMin);  // closes l-2 (NEW_LOAD)
    ASSERT_TRUE(store->CreateLoad(third, 0).ok());

    const std::vector<LoadEventRecord> events = Events(*store);
    using E = LoadEventRecord;
    ASSERT_EQ(KindsOf(events),
              (std::vector<int>{E::kCreated, E::kPassAdded, E::kPassAdded, E::kClosed,
                                E::kBodyScanned, E::kCreated, E::kClosed, E::kCreated}));
    for (std::size_t i = 1; i < events.size(); ++i) EXPECT_LT(events[i - 1].id, events[i].id);
    // Each event holds the load as it stood right after its change, and its records then.
    const std::vector<std::int64_t> passes_then = {0, 1, 2, 2, 2, 0, 0, 0};
    const std::vector<std::size_t> records_then = {0, 1, 2, 2, 3, 0, 0, 0};
    const std::vector<std::int64_t> revisions = {1, 2, 3, 4, 5, 1, 2, 1};
    for (std::size_t i = 0; i < events.size(); ++i) {
        SCOPED_TRACE(i);
        EXPECT_EQ(events[i].load.passes, passes_then[i]);
        EXPECT_EQ(events[i].records.size(), records_then[i]);
        EXPECT_EQ(events[i].load.revision, revisions[i]);
        EXPECT_EQ(events[i].load.payload, load.payload);  // bytes, NULs included
        EXPECT_EQ(events[i].load.haul_unit_id, "truck-7");
    }
    EXPECT_EQ(events[0].load.load_id, "l-1");
    EXPECT_EQ(events[0].load.state, LoadRecord::kOpen);
    EXPECT_EQ(events[0].time_us, kMin);
    EXPECT_EQ(events[0].estimate_id, 0);
    EXPECT_EQ(events[1].estimate_id, passes[0].id);
    EXPECT_EQ(events[1].through_estimate_id, passes[0].id);
    EXPECT_EQ(events[1].container_id, "bucket");
    EXPECT_EQ(events[2].records.back().id, passes[1].id);
    EXPECT_EQ(events[3].load.state, LoadRecord::kClosed);
    EXPECT_EQ(events[3].load.close_reason, LoadRecord::kExplicit);
    EXPECT_EQ(events[3].time_us, 4 * kMin);
    EXPECT_EQ(events[3].container_id, "body");  // the load's body for a close
    EXPECT_EQ(events[3].through_estimate_id, passes[1].id);
    EXPECT_EQ(events[4].estimate_id, body[0].id);
    EXPECT_EQ(events[4].records.back().load->role, LoadLink::kBodyScan);
    EXPECT_EQ(events[6].load.load_id, "l-2");
    EXPECT_EQ(events[6].load.close_reason, LoadRecord::kNewLoad);
    EXPECT_EQ(events[6].time_us, 8 * kMin);
    EXPECT_EQ(events[7].load.load_id, "l-3");
    EXPECT_EQ(events[7].load.seq, third.seq);
}

TEST_P(LoadEventStoreTest, AnIdleCloseIsAnEventBeforeThePassThatFoundItOrByTheJudgesClose) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    const std::int64_t idle = 10 * kMin;
    LoadRecord first = NewLoad("l-1", "truck-1", kMin);
    LoadRecord second = NewLoad("l-2", "truck-2", kMin);
    ASSERT_TRUE(store->CreateLoad(first, idle).ok());
    ASSERT_TRUE(store->CreateLoad(second, idle).ok());
    // A pass after the idle time: refused, the idle close kept with its event.
    std::vector<EstimateRecord> late = {Pass("l-1", 20 * kMin, LoadLink::kPass, idle),
                                        Pass("l-1", 21 * kMin, LoadLink::kBodyScan, idle)};
    ASSERT_TRUE(store->Append(late).ok());
    EXPECT_TRUE(absl::IsFailedPrecondition(late[0].rejected));
    // The judge closes l-2 through CloseLoad: idle, at its last activity plus the idle time.
    ASSERT_TRUE(store->CloseLoad("l-2", 30 * kMin, idle, std::nullopt).ok());
    // A refused join (a pass to a closed load) keeps no event.
    std::vector<EstimateRecord> refused = {Pass("l-1", 31 * kMin, LoadLink::kPass)};
    ASSERT_TRUE(store->Append(refused).ok());

    const std::vector<LoadEventRecord> events = Events(*store);
    using E = LoadEventRecord;
    ASSERT_EQ(KindsOf(events), (std::vector<int>{E::kCreated, E::kCreated, E::kClosed,
                                                 E::kBodyScanned, E::kClosed}));
    EXPECT_EQ(events[2].load.load_id, "l-1");
    EXPECT_EQ(events[2].load.close_reason, LoadRecord::kIdle);
    EXPECT_EQ(events[2].time_us, kMin + idle);
    EXPECT_EQ(events[2].records.size(), 0u);
    EXPECT_EQ(events[3].estimate_id, late[1].id);
    EXPECT_EQ(events[4].load.load_id, "l-2");
    EXPECT_EQ(events[4].load.close_reason, LoadRecord::kIdle);
    EXPECT_EQ(events[4].time_us, kMin + idle);
}

TEST_P(LoadEventStoreTest, ListedByContainerAndHaulUnitAfterAnIdNewestFirstWithout) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    LoadRecord a = NewLoad("l-a", "truck-a", kMin);
    LoadRecord b = NewLoad("l-b", "truck-b", kMin);
    ASSERT_TRUE(store->CreateLoad(a, 0).ok());
    ASSERT_TRUE(store->CreateLoad(b, 0).ok());
    std::vector<EstimateRecord> batch = {Pass("l-a", 2 * kMin, LoadLink::kPass, 0, "bucket-1"),
                                         Pass("l-b", 2 * kMin, LoadLink::kPass, 0, "bucket-2"),
                                         Pass("l-a", 3 * kMin, LoadLink::kPass, 0, "bucket-2")};
    ASSERT_TRUE(store->Append(batch).ok());
    const std::vector<LoadEventRecord> all = Events(*store);
    ASSERT_EQ(all.size(), 5u);

    LoadEventQuery of_truck;
    of_truck.haul_unit_id = "truck-a";
    const std::vector<LoadEventRecord> truck = Events(*store, of_truck);
    ASSERT_EQ(truck.size(), 3u);
    for (const LoadEventRecord& event : truck) EXPECT_EQ(event.load.load_id, "l-a");
    LoadEventQuery of_bucket;
    of_bucket.container_id = "bucket-2";
    of_bucket.after_id = all[3].id;
    const std::vector<LoadEventRecord> bucket = Events(*store, of_bucket);
    ASSERT_EQ(bucket.size(), 1u);
    EXPECT_EQ(bucket[0].estimate_id, batch[2].id);

    LoadEventQuery newest;
    newest.limit = 2;
    newest.with_records = false;
    absl::StatusOr<std::vector<LoadEventRecord>> latest = store->ListLoadEvents(newest);
    ASSERT_TRUE(latest.ok()) << latest.status();
    ASSERT_EQ(latest->size(), 2u);
    EXPECT_EQ((*latest)[0].id, all[4].id);
    EXPECT_EQ((*latest)[1].id, all[3].id);
    EXPECT_TRUE((*latest)[0].records.empty());
}

TEST_P(LoadEventStoreTest, RetentionAndPurgeRemoveEventsAsAlerts) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    const std::int64_t day = 24 * 60 * kMin;
    LoadRecord old_load = NewLoad("l-old", "truck-1", kMin);
    ASSERT_TRUE(store->CreateLoad(old_load, 0).ok());
    LoadRecord recent = NewLoad("l-new", "truck-2", 100 * day);
    ASSERT_TRUE(store->CreateLoad(recent, 0).ok());
    std::vector<EstimateRecord> batch = {
        Pass("l-new", 100 * day + kMin, LoadLink::kPass, 0, "bucket-1"),
        Pass("l-new", 100 * day + 2 * kMin, LoadLink::kPass, 0, "bucket-2")};
    ASSERT_TRUE(store->Append(batch).ok());
    RetentionPolicy policy;
    policy.max_age = std::chrono::hours(24 * 90);
    ASSERT_TRUE(store->Prune(policy, 100 * day + 3 * kMin, std::nullopt).ok());
    std::vector<LoadEventRecord> events = Events(*store);
    ASSERT_EQ(events.size(), 3u);
    EXPECT_EQ(events[0].load.load_id, "l-new");

    ASSERT_TRUE(store->DeleteContainer("bucket-1").ok());
    events = Events(*store);
    ASSERT_EQ(events.size(), 2u);
    EXPECT_EQ(events[1].container_id, "bucket-2");
}

INSTANTIATE_TEST_SUITE_P(Backends, LoadEventStoreTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
