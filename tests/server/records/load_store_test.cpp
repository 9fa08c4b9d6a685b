#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <thread>
#include <tuple>

#include "load_fixtures.hpp"
#include "server/records/load_record.hpp"
#include "server/records/record_store.hpp"
#include "test_databases.hpp"

namespace soilvol::server {
namespace {

constexpr std::int64_t kMinute = 60'000'000;

class LoadStoreTest : public ::testing::TestWithParam<std::string> {};

TEST_P(LoadStoreTest, CreateGetAndANewLoadClosesTheHaulUnitsOpenOne) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    LoadRecord first = NewLoad("l-1", "truck-7", kMinute);
    ASSERT_TRUE(store->CreateLoad(first, 0).ok());
    EXPECT_GT(first.seq, 0);
    LoadRecord taken = NewLoad("l-1", "truck-8", kMinute);
    EXPECT_TRUE(absl::IsAlreadyExists(store->CreateLoad(taken, 0)));

    absl::StatusOr<LoadRecord> got = store->GetLoad("l-1");
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_EQ(got->payload, first.payload);  // bytes, NULs included
    EXPECT_EQ(got->state, LoadRecord::kOpen);
    EXPECT_EQ(got->revision, 1);

    LoadRecord second = NewLoad("l-2", "truck-7", 3 * kMinute);
    ASSERT_TRUE(store->CreateLoad(second, 0).ok());
    got = store->GetLoad("l-1");
    ASSERT_TRUE(got.ok());
    EXPECT_EQ(got->state, LoadRecord::kClosed);
    EXPECT_EQ(got->close_reason, LoadRecord::kNewLoad);
    EXPECT_EQ(got->close_time_us, 3 * kMinute);
    EXPECT_EQ(got->revision, 2);
    EXPECT_TRUE(absl::IsNotFound(store->GetLoad("l-3").status()));
}

TEST_P(LoadStoreTest, PassesJoinOpenLoadsOnlyBodyScansAnyLoad) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    LoadRecord load = NewLoad("l-1", "truck-7", kMinute);
    ASSERT_TRUE(store->CreateLoad(load, 0).ok());
    std::vector<EstimateRecord> batch = {Pass("l-1", 2 * kMinute), Pass("l-1", 3 * kMinute),
                                         Pass("nope", 3 * kMinute)};
    ASSERT_TRUE(store->Append(batch).ok());
    EXPECT_GT(batch[0].id, 0);
    EXPECT_GT(batch[1].id, batch[0].id);
    EXPECT_EQ(batch[2].id, 0);
    EXPECT_TRUE(absl::IsNotFound(batch[2].rejected)) << batch[2].rejected;

    const absl::StatusOr<LoadRecord> closed = store->CloseLoad("l-1", 4 * kMinute, 0, 3);
    ASSERT_TRUE(closed.ok()) << closed.status();
    EXPECT_EQ(closed->close_reason, LoadRecord::kExplicit);
    EXPECT_EQ(closed->last_activity_us, 3 * kMinute);
    // Closing again returns it as it is; a stale etag is refused.
    EXPECT_EQ(store->CloseLoad("l-1", 5 * kMinute, 0, std::nullopt)->close_time_us, 4 * kMinute);
    EXPECT_TRUE(absl::IsAborted(store->CloseLoad("l-1", 5 * kMinute, 0, 3).status()));

    std::vector<EstimateRecord> late = {Pass("l-1", 5 * kMinute),
                                        Pass("l-1", 6 * kMinute, LoadLink::kBodyScan)};
    ASSERT_TRUE(store->Append(late).ok());
    EXPECT_EQ(late[0].id, 0);
    EXPECT_TRUE(absl::IsFailedPrecondition(late[0].rejected)) << late[0].rejected;
    EXPECT_GT(late[1].id, 0);

    const auto records = store->LoadEstimates({"l-1", "l-2"});
    ASSERT_TRUE(records.ok()) << records.status();
    ASSERT_EQ(records->size(), 3u);
    EXPECT_EQ((*records)[0].id, batch[0].id);
    EXPECT_EQ((*records)[2].load->role, LoadLink::kBodyScan);
    EXPECT_EQ((*records)[2].payload, "p");
}

TEST_P(LoadStoreTest, AnIdleLoadClosesAtItsLastPassPlusTheIdleTime) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    const std::int64_t idle = 10 * kMinute;
    LoadRecord load = NewLoad("l-1", "truck-7", 0);
    ASSERT_TRUE(store->CreateLoad(load, idle).ok());
    std::vector<EstimateRecord> passes = {Pass("l-1", 5 * kMinute, LoadLink::kPass, idle),
                                          Pass("l-1", 14 * kMinute, LoadLink::kPass, idle),
                                          Pass("l-1", 25 * kMinute, LoadLink::kPass, idle)};
    ASSERT_TRUE(store->Append(passes).ok());
    EXPECT_GT(passes[1].id, 0);  // 9 minutes after the last: still open
    EXPECT_TRUE(absl::IsFailedPrecondition(passes[2].rejected));  // 11 minutes after
    const absl::StatusOr<LoadRecord> got = store->GetLoad("l-1");
    ASSERT_TRUE(got.ok());
    EXPECT_EQ(got->close_reason, LoadRecord::kIdle);
    EXPECT_EQ(got->close_time_us, 24 * kMinute);

    // Listing by state counts an idle open load as closed.
    LoadRecord other = NewLoad("l-2", "truck-8", 30 * kMinute);
    ASSERT_TRUE(store->CreateLoad(other, idle).ok());
    LoadQuery open;
    open.state = LoadRecord::kOpen;
    open.open_since_us = 45 * kMinute - idle;
    EXPECT_TRUE(store->ListLoads(open)->empty());
    open.open_since_us = 35 * kMinute - idle;
    ASSERT_EQ(store->ListLoads(open)->size(), 1u);
    LoadQuery closed;
    closed.state = LoadRecord::kClosed;
    closed.open_since_us = 45 * kMinute - idle;
    EXPECT_EQ(store->ListLoads(closed)->size(), 2u);
}

TEST_P(LoadStoreTest, ListsNewestFirstByHaulUnitInPages) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    for (int i = 0; i < 5; ++i) {
        LoadRecord load = NewLoad("l-" + std::to_string(i), i % 2 == 0 ? "even" : "odd", i);
        ASSERT_TRUE(store->CreateLoad(load, 0).ok());
    }
    LoadQuery query;
    query.haul_unit_id = "even";
    query.limit = 2;
    auto page = store->ListLoads(query);
    ASSERT_TRUE(page.ok()) << page.status();
    ASSERT_EQ(page->size(), 2u);
    EXPECT_EQ((*page)[0].load_id, "l-4");
    EXPECT_EQ((*page)[1].load_id, "l-2");
    query.before_seq = page->back().seq;
    page = store->ListLoads(query);
    ASSERT_EQ(page->size(), 1u);
    EXPECT_EQ((*page)[0].load_id, "l-0");
    // Of a haul unit, only the newest is open.
    EXPECT_EQ((*page)[0].state, LoadRecord::kClosed);
}

TEST_P(LoadStoreTest, ConcurrentCreatesLeaveOneOpenLoadPerHaulUnit) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto first = db.Open();
    auto second = db.Open();  // two replicas
    ASSERT_NE(first, nullptr);
    ASSERT_NE(second, nullptr);
    std::atomic<int> failed{0};
    auto creator = [&](RecordStore* store, const std::string& prefix) {
        for (int i = 0; i < 20; ++i) {
            LoadRecord load = NewLoad(prefix + std::to_string(i), "truck-7", i);
            if (!store->CreateLoad(load, 0).ok()) ++failed;
        }
    };
    std::thread a(creator, first.get(), "a-"), b(creator, second.get(), "b-");
    a.join();
    b.join();
    EXPECT_EQ(failed.load(), 0);
    LoadQuery open;
    open.state = LoadRecord::kOpen;
    EXPECT_EQ(first->ListLoads(open)->size(), 1u);
    LoadQuery all;
    all.limit = 100;
    EXPECT_EQ(first->ListLoads(all)->size(), 40u);
}

TEST_P(LoadStoreTest, ProductionRollupSumsTheKeptRecordsButBodyScans) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    LoadRecord load = NewLoad("l-1", "truck-7", 0);
    ASSERT_TRUE(store->CreateLoad(load, 0).ok());
    auto measured = [](EstimateRecord record, double volume, int status,
                       std::optional<double> mass) {
        record.measures.volume_m3 = volume;
        record.measures.bank_volume_m3 = volume / 1.25;
        record.measures.mass_kg = mass;
        record.measures.fill_ratio = volume / 2.0;
        record.measures.load_status = status;
        record.measures.material = "clay";
        return record;
    };
    std::vector<EstimateRecord> batch = {
        measured(Pass("l-1", kMinute), 1.0, 4, 1600.0),
        measured(Pass("l-1", 2 * kMinute), 2.0, 5, 3200.0),
        measured(Pass("l-1", 3 * kMinute, LoadLink::kBodyScan), 3.1, 4, 4960.0),  // not counted
        measured(Pass("nope", 3 * kMinute), 9.0, 4, 1.0),                         // rejected
        measured(Pass("", 20 * kMinute), 0.5, 2, std::nullopt)};                  // no load
    batch[4].load.reset();
    EstimateRecord other = measured(Pass("", 5 * kMinute), 0.25, 4, std::nullopt);
    other.load.reset();
    other.container_id = "other";
    other.measures.material = "sand";
    batch.push_back(other);
    ASSERT_TRUE(store->Append(batch).ok());
    const auto sorted = [](std::vector<ProductionCell> cells) {
        std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) {
            return std::tie(a.bucket_us, a.container_id, a.haul_unit_id, a.material) <
                   std::tie(b.bucket_us, b.container_id, b.haul_unit_id, b.material);
        });
        return cells;
    };
    constexpr std::int64_t kQuarter = kProductionBucketUs, kHour = 4 * kProductionBucketUs;
    auto trucks = store->ProductionCells(0, kHour, kByHaulUnit, kQuarter);
    ASSERT_TRUE(trucks.ok()) << trucks.status();
    const std::vector<ProductionCell> by_truck = sorted(*trucks);
    ASSERT_EQ(by_truck.size(), 3u);  // 0-15: "" (other) and truck-7; 15-30: ""
    const ProductionCell& truck = by_truck[1];
    EXPECT_EQ(truck.bucket_us, 0);
    EXPECT_EQ(truck.haul_unit_id, "truck-7");
    EXPECT_EQ(truck.container_id, "");  // only its dimension's key
    EXPECT_EQ(truck.passes, 2);
    EXPECT_EQ(truck.loads, 1);  // the load's first pass
    EXPECT_DOUBLE_EQ(truck.volume_m3, 3.0);
    EXPECT_DOUBLE_EQ(truck.bank_volume_m3, 2.4);
    EXPECT_DOUBLE_EQ(truck.mass_kg, 4800.0);
    EXPECT_EQ(truck.mass_passes, 2);
    EXPECT_DOUBLE_EQ(truck.fill_ratio_sum, 1.5);
    EXPECT_EQ(truck.statuses[4], 1);
    EXPECT_EQ(truck.statuses[5], 1);
    EXPECT_EQ(by_truck[2].bucket_us, 15 * kMinute);
    EXPECT_EQ(by_truck[2].mass_passes, 0);
    EXPECT_EQ(by_truck[2].statuses[2], 1);
    // An hour's material: every pass of the hour, the body scan and the refused pass left out.
    const std::vector<ProductionCell> materials =
        sorted(*store->ProductionCells(0, kHour, kByMaterial, kHour));
    ASSERT_EQ(materials.size(), 2u);
    EXPECT_EQ(materials[0].material, "clay");
    EXPECT_EQ(materials[0].passes, 3);
    EXPECT_DOUBLE_EQ(materials[0].volume_m3, 3.5);
    EXPECT_EQ(materials[1].material, "sand");
    // The range is by bucket.
    EXPECT_EQ(store->ProductionCells(15 * kMinute, 30 * kMinute, kTotal, kQuarter)->size(), 1u);
    // Purging a container's records purges its production, every dimension of it.
    ASSERT_TRUE(store->DeleteContainer("bucket").ok());
    const auto total = store->ProductionCells(0, kHour, kTotal, kHour);
    ASSERT_TRUE(total.ok()) << total.status();
    ASSERT_EQ(total->size(), 1u);
    EXPECT_EQ((*total)[0].passes, 1);
    EXPECT_DOUBLE_EQ((*total)[0].volume_m3, 0.25);
    EXPECT_TRUE(store->ProductionCells(0, kHour, kByHaulUnit, kQuarter)->size() == 1u);
}

INSTANTIATE_TEST_SUITE_P(Backends, LoadStoreTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
