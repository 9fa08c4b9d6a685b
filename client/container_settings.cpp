#include "client/container_settings.hpp"

#include <map>

#include "absl/strings/str_cat.h"

namespace soilvol::client {

void AddSettingsOptions(CLI::App* command, ContainerSettings* s) {
    auto& o = s->options;
    o.push_back(command->add_option("--display-name", s->display_name, "name shown to people"));
    o.push_back(command->add_option("--label", s->labels, "label key=value (repeatable)"));
    o.push_back(command->add_flag("--clear-labels", s->clear_labels, "remove every label"));
    o.push_back(command->add_option("--material", s->material, "material name"));
    o.push_back(command->add_option("--density", s->density_kg_m3,
                                    "loose density of the material [kg/m^3]: mass = volume * it"));
    o.push_back(command->add_option("--bulking", s->bulking_factor,
                                    "loose over in-place volume (swell) of the material"));
    auto* volume =
        command->add_option("--target-volume", s->target_volume_m3, "target load volume [m^3]");
    auto* payload = command->add_option("--target-payload", s->target_payload_kg,
                                        "target payload [kg] (needs a density)");
    volume->excludes(payload);
    o.push_back(volume);
    o.push_back(payload);
    o.push_back(command->add_option("--under-tolerance", s->under_tolerance,
                                    "share of the target below it still LOADED_OK (0.05)"));
    o.push_back(command->add_option("--over-tolerance", s->over_tolerance,
                                    "share of the target above it still LOADED_OK (0.05)"));
    o.push_back(command->add_option("--carryback", s->carryback_m3,
                                    "loads up to this volume are CARRYBACK [m^3]"));
    o.push_back(command->add_option("--empty", s->empty_m3,
                                    "loads up to this volume (or 2 sigma) are EMPTY [m^3]"));
}

absl::Status ApplySettings(const ContainerSettings& s, v1::Container* container,
                           google::protobuf::FieldMask* mask) {
    std::map<std::string, bool> given;
    for (const CLI::Option* option : s.options) given[option->get_name()] = option->count() > 0;
    const auto path = [mask](const char* p) {
        if (mask != nullptr) mask->add_paths(p);
    };
    if (given["--display-name"]) {
        container->set_display_name(s.display_name);
        path("display_name");
    }
    if (given["--label"] || given["--clear-labels"]) {
        for (const std::string& label : s.labels) {
            const std::size_t equals = label.find('=');
            if (equals == std::string::npos) {
                return absl::InvalidArgumentError(
                    absl::StrCat("--label: '", label, "' is not key=value"));
            }
            (*container->mutable_labels())[label.substr(0, equals)] = label.substr(equals + 1);
        }
        path("labels");
    }
    struct Number {
        const char* flag;
        const char* path;
        double value;
        void (*set)(v1::Container*, double);
    };
    const Number numbers[] = {
        {"--density", "material.density_kg_m3", s.density_kg_m3,
         [](v1::Container* c, double v) { c->mutable_material()->set_density_kg_m3(v); }},
        {"--bulking", "material.bulking_factor", s.bulking_factor,
         [](v1::Container* c, double v) { c->mutable_material()->set_bulking_factor(v); }},
        {"--target-volume", "load_targets.volume_m3", s.target_volume_m3,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_volume_m3(v); }},
        {"--target-payload", "load_targets.payload_kg", s.target_payload_kg,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_payload_kg(v); }},
        {"--under-tolerance", "load_targets.under_tolerance", s.under_tolerance,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_under_tolerance(v); }},
        {"--over-tolerance", "load_targets.over_tolerance", s.over_tolerance,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_over_tolerance(v); }},
        {"--carryback", "load_targets.carryback_m3", s.carryback_m3,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_carryback_m3(v); }},
        {"--empty", "load_targets.empty_m3", s.empty_m3,
         [](v1::Container* c, double v) { c->mutable_load_targets()->set_empty_m3(v); }},
    };
    if (given["--material"]) {
        container->mutable_material()->set_name(s.material);
        path("material.name");
    }
    for (const Number& number : numbers) {
        if (!given[number.flag]) continue;
        number.set(container, number.value);
        path(number.path);
    }
    return absl::OkStatus();
}

}  // namespace soilvol::client
