#include "server/records/record_store.hpp"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <fstream>
#include <set>
#include <thread>

#include "test_databases.hpp"

namespace soilvol::server {
namespace {

EstimateRecord Draft(const std::string& container, std::int64_t time_us,
                     std::string payload = "p") {
    EstimateRecord record;
    record.container_id = container;
    record.create_time_us = time_us;
    record.request_id = "r-" + std::to_string(time_us);
    record.payload = std::move(payload);
    return record;
}

std::vector<std::int64_t> Ids(const std::vector<EstimateRecord>& records) {
    std::vector<std::int64_t> ids;
    for (const EstimateRecord& r : records) ids.push_back(r.id);
    return ids;
}

class RecordStoreTest : public ::testing::TestWithParam<std::string> {};

TEST_P(RecordStoreTest, AppendGivesIncreasingIdsAndGetReturnsTheRecord) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::string binary(1 << 20, '\0');
    for (std::size_t i = 0; i < binary.size(); ++i) binary[i] = static_cast<char>(i * 131);
    std::vector<EstimateRecord> batch = {Draft("a", 10, binary), Draft("b", 20)};
    ASSERT_TRUE(store->Append(batch).ok());
    EXPECT_GT(batch[0].id, 0);
    EXPECT_GT(batch[1].id, batch[0].id);
    std::vector<EstimateRecord> more = {Draft("a", 30)};
    ASSERT_TRUE(store->Append(more).ok());
    EXPECT_GT(more[0].id, batch[1].id);

    const absl::StatusOr<EstimateRecord> got = store->Get("a", batch[0].id);
    ASSERT_TRUE(got.ok()) << got.status();
    EXPECT_EQ(got->payload, binary);  // bytes, NULs included
    EXPECT_EQ(got->request_id, "r-10");
    EXPECT_EQ(got->create_time_us, 10);
    // Another container's id, or none, is not found.
    EXPECT_TRUE(absl::IsNotFound(store->Get("b", batch[0].id).status()));
    EXPECT_TRUE(absl::IsNotFound(store->Get("a", 999999).status()));
    EXPECT_EQ(store->kind(),
              GetParam() == "sqlite" ? std::string("sqlite") : std::string("postgresql"));
}

TEST_P(RecordStoreTest, ListsNewestFirstByContainerAndTimeAndCatchesUpOldestFirst) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> all;
    for (int i = 0; i < 10; ++i) all.push_back(Draft(i % 2 == 0 ? "even" : "odd", 100 * i));
    ASSERT_TRUE(store->Append(all).ok());

    RecordQuery query;
    query.container_id = "even";
    query.limit = 3;
    auto page = store->List(query);
    ASSERT_TRUE(page.ok()) << page.status();
    EXPECT_EQ(Ids(*page), (std::vector<std::int64_t>{all[8].id, all[6].id, all[4].id}));
    query.before_id = page->back().id;
    page = store->List(query);
    ASSERT_TRUE(page.ok());
    EXPECT_EQ(Ids(*page), (std::vector<std::int64_t>{all[2].id, all[0].id}));

    RecordQuery window;  // every container, [200, 600)
    window.start_time_us = 200;
    window.end_time_us = 600;
    window.with_payload = false;
    page = store->List(window);
    ASSERT_TRUE(page.ok());
    EXPECT_EQ(Ids(*page), (std::vector<std::int64_t>{all[5].id, all[4].id, all[3].id, all[2].id}));
    EXPECT_TRUE((*page)[0].payload.empty());

    RecordQuery after;
    after.after_id = all[6].id;
    page = store->List(after);
    ASSERT_TRUE(page.ok());
    EXPECT_EQ(Ids(*page), (std::vector<std::int64_t>{all[7].id, all[8].id, all[9].id}));
    EXPECT_EQ((*page)[0].payload, "p");
}

TEST_P(RecordStoreTest, PruneKeepsTheNewestPerContainerAndNothingTooOld) {
    const std::int64_t now = 1'000'000'000'000;
    const std::int64_t hour = 3'600'000'000;
    RetentionPolicy policy;
    policy.max_per_container = 3;
    policy.max_age = std::chrono::hours(48);
    // Every container (nullopt), or the ones named: the same outcome for "a" and "b".
    for (const std::optional<std::vector<std::string>>& containers :
         {std::optional<std::vector<std::string>>(),
          std::optional<std::vector<std::string>>({"a", "b", "never-recorded"})}) {
        TestDatabase db(GetParam());
        SOILVOL_NEED_DATABASE(db);
        auto store = db.Open();
        ASSERT_NE(store, nullptr);
        std::vector<EstimateRecord> records;
        for (int i = 0; i < 5; ++i) records.push_back(Draft("a", now - i * hour));
        records.push_back(Draft("b", now - 50 * hour));  // too old
        records.push_back(Draft("b", now));
        ASSERT_TRUE(store->Append(records).ok());
        const absl::StatusOr<std::int64_t> pruned = store->Prune(policy, now, containers);
        ASSERT_TRUE(pruned.ok()) << pruned.status();
        EXPECT_EQ(*pruned, 3);
        // "a" keeps its three newest records (by id, the order they were recorded).
        RecordQuery a;
        a.container_id = "a";
        EXPECT_EQ(Ids(*store->List(a)),
                  (std::vector<std::int64_t>{records[4].id, records[3].id, records[2].id}));
        RecordQuery b;
        b.container_id = "b";
        EXPECT_EQ(Ids(*store->List(b)), (std::vector<std::int64_t>{records[6].id}));
    }
}

TEST_P(RecordStoreTest, PruneByCountLeavesContainersItIsNotGiven) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    const std::int64_t now = 1'000'000'000'000;
    std::vector<EstimateRecord> records;
    for (int i = 0; i < 4; ++i) records.push_back(Draft("busy", now));
    for (int i = 0; i < 4; ++i) records.push_back(Draft("quiet", now));
    ASSERT_TRUE(store->Append(records).ok());
    RetentionPolicy policy;
    policy.max_per_container = 2;
    const absl::StatusOr<std::int64_t> pruned =
        store->Prune(policy, now, std::vector<std::string>{"busy"});
    ASSERT_TRUE(pruned.ok()) << pruned.status();
    EXPECT_EQ(*pruned, 2);
    RecordQuery busy;
    busy.container_id = "busy";
    EXPECT_EQ(Ids(*store->List(busy)), (std::vector<std::int64_t>{records[3].id, records[2].id}));
    RecordQuery quiet;
    quiet.container_id = "quiet";
    EXPECT_EQ(store->List(quiet)->size(), 4u);  // the next prune that names it trims it
    // Exactly at the limit: nothing to delete.
    EXPECT_EQ(*store->Prune(policy, now, std::vector<std::string>{"busy"}), 0);
}

// Two stores on one database (two replicas) write while a third watches by last-seen id:
// ids commit in order, so the watcher sees every record exactly once.
TEST_P(RecordStoreTest, AWatcherResumingAfterItsLastIdMissesNoRecordOfAnyReplica) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto one = db.Open();
    auto two = db.Open();
    auto watcher = db.Open();
    ASSERT_TRUE(one && two && watcher);
    constexpr int kPerWriter = 150;
    std::atomic<int> done{0};
    const auto write = [&](RecordStore* store, const std::string& container) {
        for (int i = 0; i < kPerWriter; ++i) {
            std::vector<EstimateRecord> batch = {Draft(container, i)};
            if (i % 3 == 0) batch.push_back(Draft(container, i));
            EXPECT_TRUE(store->Append(batch).ok());
        }
        ++done;
    };
    std::thread a(write, one.get(), "one");
    std::thread b(write, two.get(), "two");
    std::vector<std::int64_t> seen;
    std::int64_t last = 0;
    while (true) {
        const bool finished = done == 2;
        RecordQuery query;
        query.after_id = last;
        query.limit = 1000;
        query.with_payload = false;
        const auto page = watcher->List(query);
        ASSERT_TRUE(page.ok()) << page.status();
        for (const EstimateRecord& record : *page) seen.push_back(record.id);
        if (!page->empty()) last = page->back().id;
        if (finished && page->empty()) break;
    }
    a.join();
    b.join();
    RecordQuery everything;
    everything.limit = 100000;
    everything.with_payload = false;
    std::vector<std::int64_t> all = Ids(*watcher->List(everything));
    std::sort(all.begin(), all.end());
    EXPECT_EQ(all.size(), 2u * (kPerWriter + kPerWriter / 3));
    EXPECT_EQ(seen, all);
}

TEST_P(RecordStoreTest, ListsOneRegistrationAndPurgesOneContainer) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> batch = {Draft("a", 10), Draft("a", 20), Draft("a", 30),
                                         Draft("b", 40)};
    batch[0].registration_id = "reg-1";
    batch[1].registration_id = "reg-2";
    batch[2].registration_id = "reg-2";
    batch[3].registration_id = "reg-2";  // another container's registration of the same name
    ASSERT_TRUE(store->Append(batch).ok());
    RecordQuery query;
    query.container_id = "a";
    query.registration_id = "reg-2";
    const auto second = store->List(query);
    ASSERT_TRUE(second.ok()) << second.status();
    EXPECT_EQ(Ids(*second), (std::vector<std::int64_t>{batch[2].id, batch[1].id}));
    EXPECT_EQ((*second)[0].registration_id, "reg-2");
    query.registration_id = "";
    EXPECT_EQ(store->List(query)->size(), 3u);
    EXPECT_EQ(store->Get("a", batch[0].id)->registration_id, "reg-1");
    // Purging a's records leaves b's.
    const auto purged = store->DeleteContainer("a");
    ASSERT_TRUE(purged.ok()) << purged.status();
    EXPECT_EQ(*purged, 3);
    EXPECT_TRUE(store->List(query)->empty());
    query.container_id = "";
    EXPECT_EQ(Ids(*store->List(query)), (std::vector<std::int64_t>{batch[3].id}));
    EXPECT_EQ(*store->DeleteContainer("nobody"), 0);
}

// A records file written before records named their registration: opened, it gains the column,
// its records read with registration "" and new ones are kept with theirs.
TEST(RecordStore, AnOlderSqliteDatabaseGainsTheRegistrationColumn) {
    ScratchDir dir;
    const std::filesystem::path path = dir.path() / "old.sqlite3";
    {
        sqlite3* raw = nullptr;
        ASSERT_EQ(sqlite3_open(path.c_str(), &raw), SQLITE_OK);
        ASSERT_EQ(sqlite3_exec(raw,
                               "CREATE TABLE estimates (id INTEGER PRIMARY KEY AUTOINCREMENT, "
                               "container_id TEXT NOT NULL, create_time_us INTEGER NOT NULL, "
                               "request_id TEXT NOT NULL, payload BLOB NOT NULL);"
                               "INSERT INTO estimates (container_id, create_time_us, request_id, "
                               "payload) VALUES ('a', 5, 'r', 'old');",
                               nullptr, nullptr, nullptr),
                  SQLITE_OK);
        sqlite3_close(raw);
    }
    for (int reopen = 0; reopen < 2; ++reopen) {  // the second open finds the column
        auto store = OpenRecordStore("sqlite:" + path.string(), dir.path());
        ASSERT_TRUE(store.ok()) << store.status();
        RecordQuery query;
        query.container_id = "a";
        const auto rows = (*store)->List(query);
        ASSERT_TRUE(rows.ok()) << rows.status();
        ASSERT_EQ(rows->size(), 1u + reopen);
        EXPECT_EQ(rows->back().payload, "old");
        EXPECT_EQ(rows->back().registration_id, "");
        if (reopen == 0) {
            std::vector<EstimateRecord> more = {Draft("a", 6, "new")};
            more[0].registration_id = "reg-9";
            ASSERT_TRUE((*store)->Append(more).ok());
        } else {
            EXPECT_EQ(rows->front().registration_id, "reg-9");
        }
    }
}

TEST(RecordStore, UrlsNameTheirBackendAndBadOnesAreRefused) {
    ScratchDir dir;
    const auto bad = OpenRecordStore("mysql://user:secret@host/db", dir.path());
    EXPECT_TRUE(absl::IsInvalidArgument(bad.status()));
    EXPECT_EQ(std::string(bad.status().message()).find("secret"), std::string::npos);
    EXPECT_NE(std::string(bad.status().message()).find("records-url"), std::string::npos);
    const auto missing =
        OpenRecordStore("sqlite:" + (dir.path() / "no/such/dir/r.db").string(), dir.path());
    EXPECT_TRUE(absl::IsUnavailable(missing.status())) << missing.status();
    // A file that is not a database: refused, not a crash.
    const std::filesystem::path junk = dir.path() / "junk.sqlite3";
    std::ofstream(junk) << std::string(8192, 'x');
    const auto damaged = OpenRecordStore("sqlite:" + junk.string(), dir.path());
    EXPECT_FALSE(damaged.ok());
    // Unreachable PostgreSQL: Unavailable, the password not echoed.
    const auto unreachable =
        OpenRecordStore("postgresql://u:hunter2@127.0.0.1:1/db?connect_timeout=2", dir.path());
    EXPECT_TRUE(absl::IsUnavailable(unreachable.status())) << unreachable.status();
    EXPECT_EQ(std::string(unreachable.status().message()).find("hunter2"), std::string::npos);
    // The default: SQLite in the data directory.
    const auto fallback = OpenRecordStore("", dir.path());
    ASSERT_TRUE(fallback.ok());
    EXPECT_TRUE(std::filesystem::exists(dir.path() / "records.sqlite3"));
}

INSTANTIATE_TEST_SUITE_P(Backends, RecordStoreTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
