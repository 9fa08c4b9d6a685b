#pragma once

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/records/alert_record.hpp"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::server {

/// The rules a container's estimates (or a load with it as its body) go by: its own when it
/// has them, else the server's.
const v1::AlertRules& RulesFor(const v1::Container* container, const v1::AlertRules& site);

/// InvalidArgument naming `field` (alert_rules.refused_scans_in_a_row, ...) for a rule out of
/// range.
absl::Status CheckAlertRules(const v1::AlertRules& rules, const std::string& field);

/// The server's rules from --alert-rules (JSON of soilvol.v1.AlertRules, proto3 names or
/// camelCase), checked; InvalidArgument naming the flag otherwise.
absl::StatusOr<v1::AlertRules> ParseAlertRules(const std::string& json);

/// The alerts an answered estimate of `container_id` raises under `rules` (OVERLOAD,
/// CARRYBACK, LOW_COVERAGE), at `now_us`.
std::vector<v1::Alert> EstimateAlerts(const v1::AlertRules& rules,
                                      const v1::EstimateVolumeResponse& estimate,
                                      std::int64_t now_us);

/// What a refused estimate (FAILED_PRECONDITION from the engine) counts toward: REFUSED_SCANS
/// once the container's run of refusals reaches the rule; none when the rule is off.
std::optional<Refusal> RefusalOf(const v1::AlertRules& rules, const std::string& container_id,
                                 const std::string& request_id, const absl::Status& refused,
                                 std::int64_t now_us);

/// LOAD_OFF_TARGET for a closed load assessed UNDERLOADED or OVERLOADED, when `rules` ask.
std::optional<v1::Alert> LoadAlert(const v1::AlertRules& rules, const v1::Load& load,
                                   std::int64_t now_us);

/// Between the API message and the record (the alert_id is the record's id, in decimal).
AlertRecord ToAlertRecord(const v1::Alert& alert);
v1::Alert ToAlert(const AlertRecord& record);

/// The kind's name without its prefix, lower case ("overload"), as webhooks and metrics name
/// it.
std::string AlertKindLabel(int kind);

}  // namespace soilvol::server
