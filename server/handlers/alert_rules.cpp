#include "server/handlers/alert_rules.hpp"

#include <cmath>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "google/protobuf/util/json_util.h"
#include "google/protobuf/util/time_util.h"

namespace soilvol::server {
namespace {

using google::protobuf::util::TimeUtil;

constexpr int kMaxRefusedRun = 1000;

absl::Status CheckShare(std::optional<double> value, const std::string& field) {
    if (!value || (std::isfinite(*value) && *value >= 0.0 && *value <= 1.0)) {
        return absl::OkStatus();
    }
    return absl::InvalidArgumentError(
        absl::StrCat(field, ": ", *value, " is not a share between 0 and 1"));
}

v1::Alert NewAlert(v1::AlertKind kind, const v1::EstimateVolumeResponse& estimate,
                   std::int64_t now_us) {
    v1::Alert alert;
    alert.set_kind(kind);
    *alert.mutable_create_time() = TimeUtil::MicrosecondsToTimestamp(now_us);
    alert.set_container_id(estimate.container_id());
    alert.set_request_id(estimate.request_id());
    alert.set_load_id(estimate.load_id());
    return alert;
}

/// "overloaded" for LOAD_STATUS_OVERLOADED.
std::string StatusWord(v1::LoadStatus status) {
    std::string name = v1::LoadStatus_Name(status);
    name = absl::AsciiStrToLower(name.substr(std::string("LOAD_STATUS_").size()));
    return name == "loaded_ok" ? "on target" : name;
}

/// OVERLOAD or CARRYBACK for an estimate of `status` at least as likely as the rule asks.
std::optional<v1::Alert> StatusAlert(v1::AlertKind kind, v1::LoadStatus status,
                                     std::optional<double> min_probability,
                                     const v1::EstimateVolumeResponse& estimate,
                                     std::int64_t now_us) {
    const v1::LoadAssessment& load = estimate.load();
    if (!min_probability || load.status() != status ||
        load.status_probability() < *min_probability) {
        return std::nullopt;
    }
    v1::Alert alert = NewAlert(kind, estimate, now_us);
    alert.set_value(load.status_probability());
    alert.set_threshold(*min_probability);
    std::string ratio;
    if (load.has_target_ratio()) {
        ratio = absl::StrFormat(", %.0f%% of its target", 100.0 * load.target_ratio());
    }
    alert.set_message(absl::StrFormat(
        "%s: %s, %.3f m3 +- %.3f%s (probability %.2f)", estimate.container_id(), StatusWord(status),
        estimate.volume_m3(), estimate.uncertainty_m3(), ratio, load.status_probability()));
    return alert;
}

}  // namespace

const v1::AlertRules& RulesFor(const v1::Container* container, const v1::AlertRules& site) {
    return container != nullptr && container->has_alert_rules() ? container->alert_rules() : site;
}

absl::Status CheckAlertRules(const v1::AlertRules& rules, const std::string& field) {
    if (absl::Status s = CheckShare(rules.has_overload_min_probability()
                                        ? std::optional(rules.overload_min_probability())
                                        : std::nullopt,
                                    field + ".overload_min_probability");
        !s.ok()) {
        return s;
    }
    if (absl::Status s = CheckShare(rules.has_carryback_min_probability()
                                        ? std::optional(rules.carryback_min_probability())
                                        : std::nullopt,
                                    field + ".carryback_min_probability");
        !s.ok()) {
        return s;
    }
    if (absl::Status s =
            CheckShare(rules.min_scan_observed_share(), field + ".min_scan_observed_share");
        !s.ok()) {
        return s;
    }
    if (rules.refused_scans_in_a_row() < 0 || rules.refused_scans_in_a_row() > kMaxRefusedRun) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ".refused_scans_in_a_row: ", rules.refused_scans_in_a_row(),
                         " is not between 0 and ", kMaxRefusedRun));
    }
    return absl::OkStatus();
}

absl::StatusOr<v1::AlertRules> ParseAlertRules(const std::string& json) {
    v1::AlertRules rules;
    const auto parsed = google::protobuf::util::JsonStringToMessage(json, &rules);
    if (!parsed.ok()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "--alert-rules: not JSON of soilvol.v1.AlertRules: ", std::string(parsed.message())));
    }
    if (absl::Status checked = CheckAlertRules(rules, "--alert-rules"); !checked.ok()) {
        return checked;
    }
    return rules;
}

std::vector<v1::Alert> EstimateAlerts(const v1::AlertRules& rules,
                                      const v1::EstimateVolumeResponse& estimate,
                                      std::int64_t now_us) {
    std::vector<v1::Alert> out;
    for (auto alert : {StatusAlert(v1::ALERT_KIND_OVERLOAD, v1::LOAD_STATUS_OVERLOADED,
                                   rules.has_overload_min_probability()
                                       ? std::optional(rules.overload_min_probability())
                                       : std::nullopt,
                                   estimate, now_us),
                       StatusAlert(v1::ALERT_KIND_CARRYBACK, v1::LOAD_STATUS_CARRYBACK,
                                   rules.has_carryback_min_probability()
                                       ? std::optional(rules.carryback_min_probability())
                                       : std::nullopt,
                                   estimate, now_us)}) {
        if (alert) out.push_back(*std::move(alert));
    }
    const double seen = estimate.coverage().scan_observed_share();
    if (rules.min_scan_observed_share() > 0.0 && seen < rules.min_scan_observed_share()) {
        v1::Alert alert = NewAlert(v1::ALERT_KIND_LOW_COVERAGE, estimate, now_us);
        alert.set_value(seen);
        alert.set_threshold(rules.min_scan_observed_share());
        alert.set_message(absl::StrFormat(
            "%s: the scan saw %.0f%% of the opening (the rule asks for %.0f%%); %.3f m3 +- %.3f",
            estimate.container_id(), 100.0 * seen, 100.0 * rules.min_scan_observed_share(),
            estimate.volume_m3(), estimate.uncertainty_m3()));
        out.push_back(std::move(alert));
    }
    return out;
}

std::optional<Refusal> RefusalOf(const v1::AlertRules& rules, const std::string& container_id,
                                 const std::string& request_id, const absl::Status& refused,
                                 std::int64_t now_us) {
    if (rules.refused_scans_in_a_row() <= 0) return std::nullopt;
    Refusal refusal;
    refusal.alert_after = rules.refused_scans_in_a_row();
    AlertRecord& alert = refusal.alert;
    alert.kind = AlertRecord::kRefusedScans;
    alert.create_time_us = now_us;
    alert.container_id = container_id;
    alert.request_id = request_id;
    alert.value = refusal.alert_after;
    alert.threshold = refusal.alert_after;
    alert.message = absl::StrCat(container_id, ": ", refusal.alert_after,
                                 refusal.alert_after == 1 ? " scan" : " scans",
                                 " refused in a row; the last: ", refused.message());
    return refusal;
}

std::optional<v1::Alert> LoadAlert(const v1::AlertRules& rules, const v1::Load& load,
                                   std::int64_t now_us) {
    const v1::LoadAssessment& assessment = load.assessment();
    if (!rules.load_off_target() || (assessment.status() != v1::LOAD_STATUS_UNDERLOADED &&
                                     assessment.status() != v1::LOAD_STATUS_OVERLOADED)) {
        return std::nullopt;
    }
    v1::Alert alert;
    alert.set_kind(v1::ALERT_KIND_LOAD_OFF_TARGET);
    *alert.mutable_create_time() = TimeUtil::MicrosecondsToTimestamp(now_us);
    alert.set_container_id(load.body_container_id());
    alert.set_load_id(load.load_id());
    alert.set_haul_unit_id(load.haul_unit_id());
    alert.set_request_id(load.create_request_id());
    alert.set_value(assessment.target_ratio());
    alert.set_threshold(1.0);
    alert.set_message(
        absl::StrFormat("load %s (%s) closed %s: %d passes, %.3f m3 +- %.3f, %.0f%% of its target "
                        "(probability %.2f)",
                        load.load_id(), load.haul_unit_id(), StatusWord(assessment.status()),
                        load.pass_count(), load.volume_m3(), load.uncertainty_m3(),
                        100.0 * assessment.target_ratio(), assessment.status_probability()));
    return alert;
}

AlertRecord ToAlertRecord(const v1::Alert& alert) {
    AlertRecord record;
    record.kind = alert.kind();
    record.create_time_us = TimeUtil::TimestampToMicroseconds(alert.create_time());
    record.container_id = alert.container_id();
    record.load_id = alert.load_id();
    record.haul_unit_id = alert.haul_unit_id();
    record.request_id = alert.request_id();
    record.message = alert.message();
    record.value = alert.value();
    record.threshold = alert.threshold();
    return record;
}

v1::Alert ToAlert(const AlertRecord& record) {
    v1::Alert alert;
    alert.set_alert_id(absl::StrCat(record.id));
    alert.set_kind(v1::AlertKind_IsValid(record.kind) ? static_cast<v1::AlertKind>(record.kind)
                                                      : v1::ALERT_KIND_UNSPECIFIED);
    *alert.mutable_create_time() = TimeUtil::MicrosecondsToTimestamp(record.create_time_us);
    alert.set_container_id(record.container_id);
    if (record.estimate_id != 0) alert.set_estimate_id(absl::StrCat(record.estimate_id));
    alert.set_load_id(record.load_id);
    alert.set_haul_unit_id(record.haul_unit_id);
    alert.set_request_id(record.request_id);
    alert.set_message(record.message);
    alert.set_value(record.value);
    alert.set_threshold(record.threshold);
    return alert;
}

std::string AlertKindLabel(int kind) {
    if (!v1::AlertKind_IsValid(kind) || kind == 0) return "unspecified";
    const std::string name = v1::AlertKind_Name(static_cast<v1::AlertKind>(kind));
    return absl::AsciiStrToLower(name.substr(std::string("ALERT_KIND_").size()));
}

}  // namespace soilvol::server
