#include "server/webhooks/webhook_config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "server/webhooks/webhook_dispatcher.hpp"
#include "server/webhooks/webhook_signature.hpp"

namespace soilvol::server {
namespace {

std::string TempFile(const std::string& name, const std::string& text) {
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("soilvol-webhook-config-" + name);
    std::ofstream(path, std::ios::binary) << text;
    return path.string();
}

TEST(WebhookConfigTest, AFileGivesItsWebhooksWithTheirSecrets) {
    const std::string secret = TempFile("secret", "s3cret\n");
    auto targets = ParseWebhooks(
        R"({"webhooks": [
        {"webhookId": "fleet", "url": "https://fleet.example/hooks?site=7",
         "secretFile": ")" +
            secret + R"(", "kinds": ["ALERT_KIND_OVERLOAD", "ALERT_KIND_LOAD_OFF_TARGET"]},
        {"webhook_id": "ops", "url": "http://10.0.0.5:8080/", "containerIds": ["bucket-7"]}]})",
        "webhooks.json");
    ASSERT_TRUE(targets.ok()) << targets.status();
    ASSERT_EQ(targets->size(), 2u);
    const WebhookTarget& fleet = (*targets)[0];
    EXPECT_EQ(fleet.secret, "s3cret");  // the final newline dropped
    EXPECT_TRUE(fleet.url.tls);
    EXPECT_EQ(fleet.url.target, "/hooks?site=7");
    EXPECT_TRUE(Accepts(fleet, AlertRecord::kOverload, "any"));
    EXPECT_TRUE(Accepts(fleet, AlertRecord::kLoadOffTarget, ""));
    EXPECT_FALSE(Accepts(fleet, AlertRecord::kCarryback, "any"));
    const WebhookTarget& ops = (*targets)[1];
    EXPECT_TRUE(ops.secret.empty());
    EXPECT_TRUE(Accepts(ops, AlertRecord::kCarryback, "bucket-7"));
    EXPECT_FALSE(Accepts(ops, AlertRecord::kCarryback, "bucket-8"));
    EXPECT_TRUE(ParseWebhooks("{}", "empty.json")->empty());
}

TEST(WebhookConfigTest, HostileFilesAreRefusedNamingTheFileAndField) {
    const std::string empty_secret = TempFile("empty-secret", "\n");
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"[1, 2]", "not JSON of"},
        {R"({"webhooks": [{"webhookId": "Fleet", "url": "http://h/"}]})", "webhooks[0].webhook_id"},
        {R"({"webhooks": [{"webhookId": "", "url": "http://h/"}]})", "webhooks[0].webhook_id"},
        {R"({"webhooks": [{"webhookId": "a", "url": "ftp://h/"}]})", "webhooks[0].url"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://u:p@h/"}]})", "webhooks[0].url"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/"}, )"
         R"({"webhookId": "a", "url": "http://g/"}]})",
         "'a' twice"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/", "kinds": [0]}]})",
         "webhooks[0].kinds"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/", "kinds": [77]}]})",
         "webhooks[0].kinds"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/", "pendingAlerts": 3}]})",
         "only webhook_id, url"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/", "secretFile": "/nonexistent"}]})",
         "webhooks[0].secret_file"},
        {R"({"webhooks": [{"webhookId": "a", "url": "http://h/", "secretFile": ")" + empty_secret +
             R"("}]})",
         "is empty"},
    };
    for (const auto& [text, expected] : cases) {
        const auto parsed = ParseWebhooks(text, "w.json");
        ASSERT_FALSE(parsed.ok()) << text;
        EXPECT_TRUE(absl::IsInvalidArgument(parsed.status())) << text;
        EXPECT_NE(parsed.status().message().find("--webhooks-file w.json"), std::string::npos)
            << parsed.status();
        EXPECT_NE(parsed.status().message().find(expected), std::string::npos)
            << text << " -> " << parsed.status();
    }
    std::string many = R"({"webhooks": [)";
    for (int i = 0; i <= kMaxWebhooks; ++i) {
        many += (i > 0 ? "," : "") + std::string(R"({"webhookId": "w)") + std::to_string(i) +
                R"(", "url": "http://h/"})";
    }
    EXPECT_FALSE(ParseWebhooks(many + "]}", "w.json").ok());
    EXPECT_FALSE(LoadWebhooks("/nonexistent/webhooks.json").ok());
}

TEST(WebhookConfigTest, AnAttemptCarriesItsKeyAttemptAndAVerifiableSignature) {
    WebhookTarget target;
    target.config.set_webhook_id("fleet");
    target.secret = "s3cret";
    AlertRecord alert;
    alert.id = 42;
    alert.kind = AlertRecord::kOverload;
    alert.container_id = "bucket-7";
    alert.create_time_us = 1'700'000'000'123'456;
    alert.message = "bucket-7: overloaded";
    const std::string body = AlertJson(alert);
    EXPECT_NE(body.find(R"("alertId":"42")"), std::string::npos) << body;
    EXPECT_NE(body.find(R"("kind":"ALERT_KIND_OVERLOAD")"), std::string::npos) << body;
    EXPECT_NE(body.find(R"("createTime":"2023-11-14T22:13:20.123456Z")"), std::string::npos)
        << body;
    const auto headers = WebhookHeaders(target, alert, body, 3, 1'700'000'100);
    std::map<std::string, std::string> by_name(headers.begin(), headers.end());
    EXPECT_EQ(by_name["Idempotency-Key"], "42");
    EXPECT_EQ(by_name["Soilvol-Event"], "overload");
    EXPECT_EQ(by_name["Soilvol-Delivery-Attempt"], "3");
    EXPECT_EQ(by_name["Soilvol-Webhook"], "fleet");
    EXPECT_TRUE(VerifySignature(by_name["Soilvol-Signature"], "s3cret", body, 1'700'000'100, 300));
    EXPECT_FALSE(VerifySignature(by_name["Soilvol-Signature"], "other", body, 1'700'000'100, 300));
    target.secret.clear();
    for (const auto& [name, value] : WebhookHeaders(target, alert, body, 1, 0)) {
        EXPECT_NE(name, "Soilvol-Signature");  // unsigned without a secret
    }
}

}  // namespace
}  // namespace soilvol::server
