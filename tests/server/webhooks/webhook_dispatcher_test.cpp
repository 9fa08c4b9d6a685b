#include "server/webhooks/webhook_dispatcher.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "proto/convert/proto_convert.hpp"
#include "tests/server/store/scratch_dir.hpp"
#include "tests/server/webhooks/loopback_http.hpp"

namespace soilvol::server {
namespace {

using std::chrono::milliseconds;
using testing_http::Response;
using testing_http::ScriptedHttpServer;

/// A records store in a scratch directory, a recorder over it, and a webhook to `port`.
class DispatcherTest : public ::testing::Test {
  protected:
    void SetUp() override {
        auto opened = OpenSqliteRecordStore(scratch_.path() / "records.sqlite3");
        ASSERT_TRUE(opened.ok()) << opened.status();
        store_ = *std::move(opened);
        recorder_ = std::make_unique<EstimateRecorder>(*store_, EstimateRecorder::Config{});
    }

    WebhookTarget Target(int port, std::vector<v1::AlertKind> kinds = {}) const {
        WebhookTarget target;
        target.config.set_webhook_id("fleet");
        for (const v1::AlertKind kind : kinds) target.config.add_kinds(kind);
        target.url = *ParseWebhookUrl(absl::StrCat("http://127.0.0.1:", port, "/hook"));
        target.secret = "s3cret";
        return target;
    }

    static WebhookDispatcher::Config Fast() {
        WebhookDispatcher::Config config;
        config.backoff.base = milliseconds(100);
        config.backoff.cap = milliseconds(400);
        config.post.timeout = milliseconds(2000);
        config.holder = "test";
        return config;
    }

    /// Keeps a record of `container` with one alert of `kind` made `age_us` ago; its alert id.
    std::int64_t Raise(int kind, const std::string& container, std::int64_t age_us = 0) {
        EstimateRecord record;
        record.container_id = container;
        record.create_time_us = NowMicros() - age_us;
        record.payload = "p";
        AlertRecord alert;
        alert.kind = kind;
        alert.container_id = container;
        alert.create_time_us = record.create_time_us;
        alert.message = container + " alert";
        record.alerts.push_back(alert);
        std::vector<EstimateRecord> batch = {record};
        EXPECT_TRUE(store_->Append(batch).ok());
        return batch[0].alerts[0].id;
    }

    std::vector<DeliveryRecord> Log() const {
        DeliveryQuery query;
        query.limit = 1000;
        return *store_->ListDeliveries(query);
    }

    /// Waits until the log holds `n` attempts (oldest first then).
    std::vector<DeliveryRecord> WaitForAttempts(std::size_t n) const {
        for (int i = 0; i < 200 && Log().size() < n; ++i)
            std::this_thread::sleep_for(milliseconds(25));
        std::vector<DeliveryRecord> log = Log();
        std::reverse(log.begin(), log.end());
        return log;
    }

    ScratchDir scratch_;
    std::unique_ptr<RecordStore> store_;
    std::unique_ptr<EstimateRecorder> recorder_;
};

TEST_F(DispatcherTest, AlertsArriveInOrderSignedAndAFailureIsRetriedUnderItsKey) {
    ScriptedHttpServer receiver(
        {Response("503 Service Unavailable", "busy"), Response("204 No Content", "")});
    // The webhook's position starts at the newest alert: this one is not its.
    Raise(AlertRecord::kOverload, "before");
    WebhookDispatcher dispatcher(*recorder_, {Target(receiver.port())}, Fast());
    std::this_thread::sleep_for(milliseconds(300));  // leased, at the newest alert
    const std::int64_t first = Raise(AlertRecord::kOverload, "bucket-7");
    const std::int64_t second = Raise(AlertRecord::kCarryback, "bucket-7");
    const std::vector<DeliveryRecord> log = WaitForAttempts(3);
    ASSERT_EQ(log.size(), 3u);
    EXPECT_EQ(log[0].alert_id, first);
    EXPECT_EQ(log[0].outcome, DeliveryRecord::kFailed);
    EXPECT_EQ(log[0].http_status, 503);
    EXPECT_EQ(log[0].error, "HTTP 503: busy");
    EXPECT_EQ(log[1].alert_id, first);  // the same alert again, before the next one
    EXPECT_EQ(log[1].attempt, 2);
    EXPECT_EQ(log[1].outcome, DeliveryRecord::kDelivered);
    EXPECT_GE(log[1].time_us - log[0].time_us, 50'000);  // at least half the 100 ms backoff
    EXPECT_EQ(log[2].alert_id, second);
    const std::vector<std::string> requests = receiver.requests();
    ASSERT_EQ(requests.size(), 3u);
    for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_TRUE(absl::StrContains(requests[i], absl::StrCat("Idempotency-Key: ", first)))
            << requests[i];
        EXPECT_TRUE(absl::StrContains(requests[i], "Soilvol-Signature: t="));
    }
    EXPECT_TRUE(absl::StrContains(requests[1], "Soilvol-Delivery-Attempt: 2"));
    EXPECT_TRUE(absl::StrContains(requests[2], "\"kind\":\"ALERT_KIND_CARRYBACK\""));
    dispatcher.Shutdown();
    const std::vector<WebhookState> states = *store_->WebhookStates({"fleet"});
    ASSERT_EQ(states.size(), 1u);
    EXPECT_EQ(states[0].cursor, second);
    EXPECT_EQ(states[0].failing_attempts, 0);
    EXPECT_EQ(states[0].pending, 0);
    // Stopped, it gave its lease up: another process takes the webhook at once.
    EXPECT_TRUE(store_->LeaseWebhook("fleet", "other", NowMicros(), NowMicros() + 1)->has_value());
}

TEST_F(DispatcherTest, AlertsItDoesNotTakeArePassedAndOldOnesAbandoned) {
    ScriptedHttpServer receiver(Response("500 Internal Server Error", "down"));
    WebhookDispatcher::Config config = Fast();
    config.max_age = std::chrono::seconds(3600);
    WebhookDispatcher dispatcher(*recorder_, {Target(receiver.port(), {v1::ALERT_KIND_OVERLOAD})},
                                 config);
    std::this_thread::sleep_for(milliseconds(300));
    Raise(AlertRecord::kCarryback, "bucket-7");  // not a kind it takes: never posted
    const std::int64_t old = Raise(AlertRecord::kOverload, "bucket-7", 2LL * 3600 * 1'000'000);
    const std::vector<DeliveryRecord> log = WaitForAttempts(1);
    ASSERT_EQ(log.size(), 1u);
    EXPECT_EQ(log[0].alert_id, old);
    EXPECT_EQ(log[0].outcome, DeliveryRecord::kAbandoned);
    EXPECT_EQ(log[0].http_status, 0);
    EXPECT_TRUE(receiver.requests().empty());
    EXPECT_EQ(dispatcher.counts()["fleet"].abandoned, 1u);
}

}  // namespace
}  // namespace soilvol::server
