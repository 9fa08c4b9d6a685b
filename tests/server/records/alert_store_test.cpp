#include <gtest/gtest.h>

#include "server/records/alert_record.hpp"
#include "server/records/record_store.hpp"
#include "test_databases.hpp"

namespace soilvol::server {
namespace {

constexpr std::int64_t kOneSecond = 1'000'000;
constexpr std::int64_t kAnHour = 3600 * kOneSecond;

AlertRecord Alert(int kind, const std::string& container_id, std::int64_t time_us) {
    AlertRecord alert;
    alert.kind = kind;
    alert.container_id = container_id;
    alert.create_time_us = time_us;
    alert.request_id = "req";
    alert.message = container_id + " alert";
    alert.value = 0.9;
    alert.threshold = 0.5;
    return alert;
}

EstimateRecord Kept(const std::string& container_id, std::int64_t time_us,
                    std::vector<AlertRecord> alerts = {}) {
    EstimateRecord record;
    record.container_id = container_id;
    record.create_time_us = time_us;
    record.payload = "p";
    record.alerts = std::move(alerts);
    return record;
}

EstimateRecord Refused(const std::string& container_id, std::int64_t time_us, int alert_after) {
    EstimateRecord record;
    record.container_id = container_id;
    record.create_time_us = time_us;
    record.refusal = Refusal{alert_after, Alert(AlertRecord::kRefusedScans, container_id, time_us)};
    return record;
}

std::vector<AlertRecord> AllAlerts(RecordStore& store) {
    AlertQuery query;
    query.after_id = 0;
    query.limit = 1000;
    absl::StatusOr<std::vector<AlertRecord>> alerts = store.ListAlerts(query);
    EXPECT_TRUE(alerts.ok()) << alerts.status();
    return alerts.ok() ? *alerts : std::vector<AlertRecord>();
}

class AlertStoreTest : public ::testing::TestWithParam<std::string> {};

TEST_P(AlertStoreTest, AnEstimatesAlertsAreKeptWithItAndListedByContainerAndKind) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> batch = {
        Kept("a", kOneSecond, {Alert(AlertRecord::kOverload, "a", kOneSecond)}),
        Kept("b", 2 * kOneSecond,
             {Alert(AlertRecord::kCarryback, "b", 2 * kOneSecond),
              Alert(AlertRecord::kLowCoverage, "b", 2 * kOneSecond)}),
        Kept("a", 3 * kOneSecond)};
    ASSERT_TRUE(store->Append(batch).ok());
    EXPECT_GT(batch[0].alerts[0].id, 0);
    EXPECT_EQ(batch[0].alerts[0].estimate_id, batch[0].id);
    EXPECT_EQ(batch[1].alerts[1].estimate_id, batch[1].id);

    const std::vector<AlertRecord> all = AllAlerts(*store);
    ASSERT_EQ(all.size(), 3u);
    EXPECT_LT(all[0].id, all[1].id);
    EXPECT_LT(all[1].id, all[2].id);
    EXPECT_EQ(all[0].kind, AlertRecord::kOverload);
    EXPECT_EQ(all[0].message, "a alert");
    EXPECT_DOUBLE_EQ(all[0].value, 0.9);
    EXPECT_EQ(all[2].estimate_id, batch[1].id);

    AlertQuery of_b;
    of_b.container_id = "b";
    absl::StatusOr<std::vector<AlertRecord>> b = store->ListAlerts(of_b);
    ASSERT_TRUE(b.ok());
    ASSERT_EQ(b->size(), 2u);
    EXPECT_GT((*b)[0].id, (*b)[1].id);  // newest first
    AlertQuery coverage;
    coverage.kind = AlertRecord::kLowCoverage;
    EXPECT_EQ(store->ListAlerts(coverage)->size(), 1u);
    AlertQuery page;
    page.before_id = all[2].id;
    page.limit = 1;
    ASSERT_EQ(store->ListAlerts(page)->size(), 1u);
    EXPECT_EQ(store->ListAlerts(page)->front().id, all[1].id);
    AlertQuery window;
    window.start_time_us = 2 * kOneSecond;
    window.end_time_us = 3 * kOneSecond;
    EXPECT_EQ(store->ListAlerts(window)->size(), 2u);
}

TEST_P(AlertStoreTest, ARunOfRefusalsRaisesOneAlertAtItsNthAndAKeptRecordEndsIt) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> batch;
    for (int i = 0; i < 4; ++i) batch.push_back(Refused("a", i * kOneSecond, 3));
    batch.push_back(Refused("b", 5 * kOneSecond, 3));  // another container's run
    ASSERT_TRUE(store->Append(batch).ok());
    for (const EstimateRecord& record : batch) EXPECT_EQ(record.id, 0);  // not kept
    RecordQuery records;
    EXPECT_TRUE(store->List(records)->empty());
    std::vector<AlertRecord> alerts = AllAlerts(*store);
    ASSERT_EQ(alerts.size(), 1u);  // at the 3rd, not again at the 4th
    EXPECT_EQ(alerts[0].kind, AlertRecord::kRefusedScans);
    EXPECT_EQ(alerts[0].container_id, "a");
    EXPECT_EQ(alerts[0].create_time_us, 2 * kOneSecond);

    std::vector<EstimateRecord> later = {Kept("a", 6 * kOneSecond), Refused("a", 7 * kOneSecond, 3),
                                         Refused("a", 8 * kOneSecond, 3)};
    ASSERT_TRUE(store->Append(later).ok());
    EXPECT_EQ(AllAlerts(*store).size(), 1u);  // the new run is at 2
    std::vector<EstimateRecord> third = {Refused("a", 9 * kOneSecond, 3),
                                         Refused("b", 9 * kOneSecond, 3),
                                         Refused("b", 9 * kOneSecond, 3)};
    ASSERT_TRUE(store->Append(third).ok());
    alerts = AllAlerts(*store);
    ASSERT_EQ(alerts.size(), 3u);
    EXPECT_EQ(alerts[1].container_id, "a");
    EXPECT_EQ(alerts[2].container_id, "b");
}

TEST_P(AlertStoreTest, AClosedLoadIsJudgedOnceAndAnIdleOpenOneIsFound) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    for (const char* id : {"l-1", "l-2"}) {
        LoadRecord load;
        load.load_id = id;
        load.haul_unit_id = std::string("truck-") + id;
        load.create_time_us = load.update_time_us = load.last_activity_us = kAnHour;
        ASSERT_TRUE(store->CreateLoad(load, 0).ok());
    }
    absl::StatusOr<std::vector<std::string>> unjudged = store->UnjudgedLoads(0, 10);
    ASSERT_TRUE(unjudged.ok()) << unjudged.status();
    EXPECT_TRUE(unjudged->empty());  // both open and active
    ASSERT_TRUE(store->CloseLoad("l-1", 2 * kAnHour, 0, std::nullopt).ok());
    EXPECT_EQ(*store->UnjudgedLoads(0, 10), std::vector<std::string>{"l-1"});
    // l-2 idle since kAnHour: found once the idle limit passes its last activity.
    EXPECT_EQ(*store->UnjudgedLoads(kAnHour + 1, 10), (std::vector<std::string>{"l-1", "l-2"}));

    std::optional<AlertRecord> alert = Alert(AlertRecord::kLoadOffTarget, "", 2 * kAnHour);
    alert->load_id = "l-1";
    absl::StatusOr<bool> judged = store->JudgeLoad("l-1", alert);
    ASSERT_TRUE(judged.ok()) << judged.status();
    EXPECT_TRUE(*judged);
    EXPECT_GT(alert->id, 0);
    std::optional<AlertRecord> again = Alert(AlertRecord::kLoadOffTarget, "", 3 * kAnHour);
    EXPECT_FALSE(*store->JudgeLoad("l-1", again));  // another replica, later: nothing
    std::optional<AlertRecord> none;
    EXPECT_FALSE(*store->JudgeLoad("no-such-load", none));
    const std::vector<AlertRecord> alerts = AllAlerts(*store);
    ASSERT_EQ(alerts.size(), 1u);
    EXPECT_EQ(alerts[0].load_id, "l-1");
    EXPECT_TRUE(store->UnjudgedLoads(0, 10)->empty());
}

TEST_P(AlertStoreTest, AWebhookLeaseIsOneHoldersAndItsPositionStartsAtTheNewestAlert) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> before = {
        Kept("a", kOneSecond, {Alert(AlertRecord::kOverload, "a", kOneSecond)})};
    ASSERT_TRUE(store->Append(before).ok());
    auto a = store->LeaseWebhook("fleet", "replica-a", 10 * kOneSecond, 40 * kOneSecond);
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_TRUE(a->has_value());
    EXPECT_EQ((*a)->cursor, before[0].alerts[0].id);  // alerts before it are not its
    auto b = store->LeaseWebhook("fleet", "replica-b", 20 * kOneSecond, 50 * kOneSecond);
    ASSERT_TRUE(b.ok());
    EXPECT_FALSE(b->has_value());  // a holds it until 40 s
    EXPECT_TRUE(
        store->LeaseWebhook("fleet", "replica-a", 30 * kOneSecond, 60 * kOneSecond)->has_value());

    std::vector<EstimateRecord> after = {
        Kept("a", 31 * kOneSecond, {Alert(AlertRecord::kOverload, "a", 31 * kOneSecond)})};
    ASSERT_TRUE(store->Append(after).ok());
    WebhookState state = **a;
    state.cursor = after[0].alerts[0].id;
    state.last_delivery_us = 32 * kOneSecond;
    DeliveryRecord attempt;
    attempt.webhook_id = "fleet";
    attempt.alert_id = after[0].alerts[0].id;
    attempt.time_us = 32 * kOneSecond;
    attempt.outcome = DeliveryRecord::kDelivered;
    attempt.http_status = 200;
    attempt.latency_ms = 12.5;
    ASSERT_TRUE(store->SaveWebhook("replica-a", state, &attempt).ok());
    EXPECT_GT(attempt.id, 0);

    // The lease lapses: b takes over, and a's late write is refused.
    b = store->LeaseWebhook("fleet", "replica-b", 61 * kOneSecond, 91 * kOneSecond);
    ASSERT_TRUE(b.ok() && b->has_value());
    EXPECT_EQ((*b)->cursor, after[0].alerts[0].id);
    EXPECT_EQ((*b)->last_delivery_us, 32 * kOneSecond);
    EXPECT_TRUE(absl::IsAborted(store->SaveWebhook("replica-a", state, nullptr)));
    // b shuts down: its lease goes at once, and a takes over long before it would have lapsed.
    EXPECT_TRUE(store->ReleaseWebhook("fleet", "replica-a").ok());  // not a's: nothing
    EXPECT_FALSE(
        store->LeaseWebhook("fleet", "replica-a", 62 * kOneSecond, 92 * kOneSecond)->has_value());
    ASSERT_TRUE(store->ReleaseWebhook("fleet", "replica-b").ok());
    EXPECT_TRUE(
        store->LeaseWebhook("fleet", "replica-a", 63 * kOneSecond, 93 * kOneSecond)->has_value());

    auto states = store->WebhookStates({"fleet", "never-leased"});
    ASSERT_TRUE(states.ok());
    ASSERT_EQ(states->size(), 1u);
    EXPECT_EQ((*states)[0].pending, 0);
    DeliveryQuery log;
    log.webhook_id = "fleet";
    auto deliveries = store->ListDeliveries(log);
    ASSERT_TRUE(deliveries.ok()) << deliveries.status();
    ASSERT_EQ(deliveries->size(), 1u);
    EXPECT_EQ((*deliveries)[0].http_status, 200);
    EXPECT_DOUBLE_EQ((*deliveries)[0].latency_ms, 12.5);
    log.alert_id = before[0].alerts[0].id;
    EXPECT_TRUE(store->ListDeliveries(log)->empty());
}

TEST_P(AlertStoreTest, RetentionAndAPurgeRemoveAlerts) {
    TestDatabase db(GetParam());
    SOILVOL_NEED_DATABASE(db);
    auto store = db.Open();
    ASSERT_NE(store, nullptr);
    std::vector<EstimateRecord> batch = {
        Kept("old", kOneSecond, {Alert(AlertRecord::kOverload, "old", kOneSecond)}),
        Kept("new", 100 * kAnHour, {Alert(AlertRecord::kOverload, "new", 100 * kAnHour)}),
        Kept("gone", 100 * kAnHour, {Alert(AlertRecord::kOverload, "gone", 100 * kAnHour)})};
    ASSERT_TRUE(store->Append(batch).ok());
    RetentionPolicy policy;
    policy.max_age = std::chrono::hours(24);
    ASSERT_TRUE(store->Prune(policy, 101 * kAnHour, std::nullopt).ok());
    ASSERT_TRUE(store->DeleteContainer("gone").ok());
    const std::vector<AlertRecord> alerts = AllAlerts(*store);
    ASSERT_EQ(alerts.size(), 1u);
    EXPECT_EQ(alerts[0].container_id, "new");
}

INSTANTIATE_TEST_SUITE_P(Backends, AlertStoreTest, ::testing::Values("sqlite", "postgresql"),
                         [](const auto& param_info) { return param_info.param; });

}  // namespace
}  // namespace soilvol::server
