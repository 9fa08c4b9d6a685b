#include "server/handlers/alert_rules.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace soilvol::server {
namespace {

constexpr std::int64_t kNow = 1'700'000'000'000'000;

v1::EstimateVolumeResponse Estimate(v1::LoadStatus status, double probability, double seen) {
    v1::EstimateVolumeResponse estimate;
    estimate.set_container_id("bucket-7");
    estimate.set_request_id("req-1");
    estimate.set_load_id("load-1");
    estimate.set_volume_m3(3.4);
    estimate.set_uncertainty_m3(0.05);
    estimate.mutable_load()->set_status(status);
    estimate.mutable_load()->set_status_probability(probability);
    estimate.mutable_load()->set_target_ratio(1.13);
    estimate.mutable_coverage()->set_scan_observed_share(seen);
    return estimate;
}

v1::AlertRules Rules() {
    v1::AlertRules rules;
    rules.set_overload_min_probability(0.8);
    rules.set_carryback_min_probability(0.5);
    rules.set_refused_scans_in_a_row(3);
    rules.set_min_scan_observed_share(0.6);
    rules.set_load_off_target(true);
    return rules;
}

TEST(AlertRulesTest, AnOverloadAlertsAtTheRulesProbabilityAndNotBelow) {
    std::vector<v1::Alert> alerts =
        EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_OVERLOADED, 0.8, 0.9), kNow);
    ASSERT_EQ(alerts.size(), 1u);
    EXPECT_EQ(alerts[0].kind(), v1::ALERT_KIND_OVERLOAD);
    EXPECT_EQ(alerts[0].container_id(), "bucket-7");
    EXPECT_EQ(alerts[0].load_id(), "load-1");
    EXPECT_EQ(alerts[0].request_id(), "req-1");
    EXPECT_DOUBLE_EQ(alerts[0].value(), 0.8);
    EXPECT_DOUBLE_EQ(alerts[0].threshold(), 0.8);
    EXPECT_NE(alerts[0].message().find("overloaded, 3.400 m3"), std::string::npos)
        << alerts[0].message();
    EXPECT_NE(alerts[0].message().find("113% of its target"), std::string::npos);
    EXPECT_TRUE(
        EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_OVERLOADED, 0.79, 0.9), kNow).empty());
    EXPECT_TRUE(
        EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_LOADED_OK, 0.99, 0.9), kNow).empty());
    v1::AlertRules off = Rules();
    off.clear_overload_min_probability();
    EXPECT_TRUE(EstimateAlerts(off, Estimate(v1::LOAD_STATUS_OVERLOADED, 1.0, 0.9), kNow).empty());
}

TEST(AlertRulesTest, CarrybackAndLowCoverageAlertTogether) {
    std::vector<v1::Alert> alerts =
        EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_CARRYBACK, 0.6, 0.55), kNow);
    ASSERT_EQ(alerts.size(), 2u);
    EXPECT_EQ(alerts[0].kind(), v1::ALERT_KIND_CARRYBACK);
    EXPECT_EQ(alerts[1].kind(), v1::ALERT_KIND_LOW_COVERAGE);
    EXPECT_DOUBLE_EQ(alerts[1].value(), 0.55);
    EXPECT_DOUBLE_EQ(alerts[1].threshold(), 0.6);
    EXPECT_NE(alerts[1].message().find("saw 55% of the opening"), std::string::npos)
        << alerts[1].message();
    // Exactly at the share is enough.
    EXPECT_EQ(EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_EMPTY, 1.0, 0.6), kNow).size(), 0u);
}

TEST(AlertRulesTest, ARefusalCountsOnlyWhenTheRuleIsOn) {
    const absl::Status refused = absl::FailedPreconditionError("the scan does not align");
    std::optional<Refusal> refusal = RefusalOf(Rules(), "bucket-7", "req-2", refused, kNow);
    ASSERT_TRUE(refusal.has_value());
    EXPECT_EQ(refusal->alert_after, 3);
    EXPECT_EQ(refusal->alert.kind, AlertRecord::kRefusedScans);
    EXPECT_EQ(refusal->alert.message,
              "bucket-7: 3 scans refused in a row; the last: the scan does not align");
    v1::AlertRules off = Rules();
    off.set_refused_scans_in_a_row(0);
    EXPECT_FALSE(RefusalOf(off, "bucket-7", "req-2", refused, kNow).has_value());
}

TEST(AlertRulesTest, ALoadOffTargetAlertsWhenItClosesUnderOrOver) {
    v1::Load load;
    load.set_load_id("load-9");
    load.set_haul_unit_id("truck-3");
    load.set_pass_count(4);
    load.set_volume_m3(11.0);
    load.mutable_assessment()->set_status(v1::LOAD_STATUS_UNDERLOADED);
    load.mutable_assessment()->set_target_ratio(0.85);
    load.mutable_assessment()->set_status_probability(0.97);
    std::optional<v1::Alert> alert = LoadAlert(Rules(), load, kNow);
    ASSERT_TRUE(alert.has_value());
    EXPECT_EQ(alert->kind(), v1::ALERT_KIND_LOAD_OFF_TARGET);
    EXPECT_EQ(alert->haul_unit_id(), "truck-3");
    EXPECT_DOUBLE_EQ(alert->value(), 0.85);
    EXPECT_NE(alert->message().find("closed underloaded: 4 passes"), std::string::npos)
        << alert->message();
    load.mutable_assessment()->set_status(v1::LOAD_STATUS_LOADED_OK);
    EXPECT_FALSE(LoadAlert(Rules(), load, kNow).has_value());
    load.mutable_assessment()->set_status(v1::LOAD_STATUS_OVERLOADED);
    v1::AlertRules off = Rules();
    off.set_load_off_target(false);
    EXPECT_FALSE(LoadAlert(off, load, kNow).has_value());
}

TEST(AlertRulesTest, AContainersOwnRulesReplaceTheServers) {
    v1::Container container;
    const v1::AlertRules site = Rules();
    EXPECT_EQ(&RulesFor(&container, site), &site);
    container.mutable_alert_rules()->set_refused_scans_in_a_row(7);
    EXPECT_EQ(RulesFor(&container, site).refused_scans_in_a_row(), 7);
    EXPECT_FALSE(RulesFor(&container, site).has_overload_min_probability());
    EXPECT_EQ(&RulesFor(nullptr, site), &site);
}

TEST(AlertRulesTest, RulesOutOfRangeAreRefusedNamingTheField) {
    v1::AlertRules rules = Rules();
    rules.set_overload_min_probability(1.5);
    absl::Status status = CheckAlertRules(rules, "container.alert_rules");
    EXPECT_TRUE(absl::IsInvalidArgument(status));
    EXPECT_NE(status.message().find("container.alert_rules.overload_min_probability"),
              std::string::npos);
    rules = Rules();
    rules.set_refused_scans_in_a_row(1001);
    EXPECT_NE(CheckAlertRules(rules, "r").message().find("r.refused_scans_in_a_row"),
              std::string::npos);
    rules = Rules();
    rules.set_min_scan_observed_share(std::nan(""));
    EXPECT_FALSE(CheckAlertRules(rules, "r").ok());
    EXPECT_TRUE(CheckAlertRules(Rules(), "r").ok());

    absl::StatusOr<v1::AlertRules> parsed =
        ParseAlertRules(R"({"overloadMinProbability":0.5,"refused_scans_in_a_row":2})");
    ASSERT_TRUE(parsed.ok()) << parsed.status();
    EXPECT_DOUBLE_EQ(parsed->overload_min_probability(), 0.5);
    EXPECT_EQ(parsed->refused_scans_in_a_row(), 2);
    EXPECT_FALSE(parsed->has_carryback_min_probability());
    EXPECT_TRUE(ParseAlertRules("{}").ok());
    EXPECT_NE(ParseAlertRules("{not json").status().message().find("--alert-rules"),
              std::string::npos);
    EXPECT_FALSE(ParseAlertRules(R"({"minScanObservedShare":-1})").ok());
}

TEST(AlertRulesTest, AnAlertKeepsItsFieldsThroughItsRecord) {
    v1::Alert alert =
        EstimateAlerts(Rules(), Estimate(v1::LOAD_STATUS_OVERLOADED, 0.9, 0.9), kNow).front();
    AlertRecord record = ToAlertRecord(alert);
    record.id = 42;
    record.estimate_id = 7;
    const v1::Alert back = ToAlert(record);
    EXPECT_EQ(back.alert_id(), "42");
    EXPECT_EQ(back.estimate_id(), "7");
    EXPECT_EQ(back.kind(), alert.kind());
    EXPECT_EQ(back.create_time().seconds(), alert.create_time().seconds());
    EXPECT_EQ(back.message(), alert.message());
    EXPECT_EQ(AlertKindLabel(AlertRecord::kLoadOffTarget), "load_off_target");
    EXPECT_EQ(AlertKindLabel(99), "unspecified");
}

}  // namespace
}  // namespace soilvol::server
