#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "google/protobuf/field_mask.pb.h"
#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// What a container knows of its job, from the command line: `register` sends them with the
/// scan, `containers update` sends the given ones with an update mask naming exactly those.
struct ContainerSettings {
    std::string display_name;
    std::vector<std::string> labels;  ///< key=value
    bool clear_labels = false;
    std::string material;
    double density_kg_m3 = 0.0;
    double bulking_factor = 0.0;
    double target_volume_m3 = 0.0;
    double target_payload_kg = 0.0;
    double under_tolerance = 0.0;
    double over_tolerance = 0.0;
    double carryback_m3 = 0.0;
    double empty_m3 = 0.0;
    std::vector<CLI::Option*> options;  ///< to tell which were given
};

/// Adds --display-name, --label k=v (repeatable), --clear-labels, --material, --density,
/// --bulking, --target-volume | --target-payload, --under-tolerance, --over-tolerance,
/// --carryback, --empty.
void AddSettingsOptions(CLI::App* command, ContainerSettings* settings);

/// The given settings into `container`, and their paths into `mask` (when not null).
/// InvalidArgument for a label that is not key=value.
absl::Status ApplySettings(const ContainerSettings& settings, v1::Container* container,
                           google::protobuf::FieldMask* mask);

}  // namespace soilvol::client
