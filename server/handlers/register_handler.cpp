#include <algorithm>
#include <array>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/model/model_codec.hpp"
#include "core/pipeline/registration.hpp"
#include "google/protobuf/util/field_mask_util.h"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/handlers/mesh_request.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/handlers/stored_record.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

constexpr double kMaxRangeLimitM = 1000.0;

absl::StatusOr<model::ModelConfig> ModelConfigFor(const v1::RegisterContainerRequest& request) {
    model::ModelConfig config;
    if (request.has_max_range_m()) {
        const double range = request.max_range_m();
        if (!std::isfinite(range) || range <= 0.0 || range > kMaxRangeLimitM) {
            return absl::InvalidArgumentError(
                absl::StrCat("max_range_m: must be in (0, ", kMaxRangeLimitM, "] metres"));
        }
        config.preprocess.max_range_m = range;
    }
    return config;
}

/// The settings of a container (what UpdateContainer can change) by their rules, fields named
/// by `prefix` ("" for a registration, "container." for an update).
absl::Status CheckSettings(const v1::Container& container, const std::string& prefix) {
    SOILVOL_RETURN_IF_ERROR(
        ValidateDisplayName(container.display_name(), absl::StrCat(prefix, "display_name")));
    const std::string labels = absl::StrCat(prefix, "labels");
    if (container.labels_size() > kMaxLabels) {
        return absl::InvalidArgumentError(
            absl::StrCat(labels, ": at most ", kMaxLabels, " (got ", container.labels_size(), ")"));
    }
    for (const auto& [key, value] : container.labels()) {
        SOILVOL_RETURN_IF_ERROR(ValidateLabel(key, value, labels));
    }
    absl::StatusOr<LoadRules> rules = ToLoadRules(container.material(), container.load_targets());
    if (!rules.ok()) {
        return absl::InvalidArgumentError(absl::StrCat(prefix, rules.status().message()));
    }
    return CheckAlertRules(container.alert_rules(), absl::StrCat(prefix, "alert_rules"));
}

/// The request's settings into `container`, checked.
absl::Status ApplySettings(const v1::RegisterContainerRequest& request, v1::Container* container) {
    container->set_display_name(request.display_name());
    *container->mutable_labels() = request.labels();
    if (request.has_material()) *container->mutable_material() = request.material();
    if (request.has_load_targets()) *container->mutable_load_targets() = request.load_targets();
    if (request.has_alert_rules()) *container->mutable_alert_rules() = request.alert_rules();
    return CheckSettings(*container, "");
}

constexpr std::array<const char*, 5> kSettings = {"display_name", "labels", "material",
                                                  "load_targets", "alert_rules"};

/// The mask of an update (AIP-134): the request's paths that are settings or fields inside
/// one ("*" for all settings), or - without paths - the settings the request sets. Paths of
/// the container's other fields (its id, etag, and output-only figures, which a client that
/// sends back what it read names) are ignored; paths of no field are an error.
absl::StatusOr<google::protobuf::FieldMask> UpdateMaskOf(
    const v1::UpdateContainerRequest& request) {
    google::protobuf::FieldMask mask;
    const v1::Container& given = request.container();
    if (request.update_mask().paths_size() == 0) {
        if (!given.display_name().empty()) mask.add_paths("display_name");
        if (given.labels_size() > 0) mask.add_paths("labels");
        if (given.has_material()) mask.add_paths("material");
        if (given.has_load_targets()) mask.add_paths("load_targets");
        if (given.has_alert_rules()) mask.add_paths("alert_rules");
    }
    for (const std::string& path : request.update_mask().paths()) {
        if (path == "*") {
            for (const char* setting : kSettings) mask.add_paths(setting);
            continue;
        }
        if (!google::protobuf::util::FieldMaskUtil::GetFieldDescriptors(v1::Container::descriptor(),
                                                                        path, nullptr)) {
            return absl::InvalidArgumentError(
                absl::StrCat("update_mask: '", path, "' is no field of Container"));
        }
        const std::string top = path.substr(0, path.find('.'));
        if (std::find(kSettings.begin(), kSettings.end(), top) != kSettings.end()) {
            mask.add_paths(path);
        }
    }
    if (mask.paths_size() == 0) {
        return absl::InvalidArgumentError(
            "update_mask: names nothing UpdateContainer changes (display_name, labels, material, "
            "load_targets, alert_rules, or a field of the last three)");
    }
    return mask;
}

/// Which of scan, opening and mesh a registration has: a scan with its opening, a mesh, or a
/// point-cloud scan with its opening and a mesh.
absl::Status CheckSources(const v1::RegisterContainerRequest& request) {
    if (!request.has_mesh() && !request.has_scan()) {
        return absl::InvalidArgumentError(
            "scan: is required without a mesh: give a scan of the empty container (cloud or "
            "stereo) with its opening, the container's mesh, or both");
    }
    if (request.has_scan()) {
        if (!request.has_opening()) {
            return absl::InvalidArgumentError("opening: is required (corners or pixel_corners)");
        }
        if (request.has_mesh() && request.scan().has_stereo()) {
            return absl::InvalidArgumentError(
                "mesh: goes with a point-cloud scan or alone; stereo registrations take none");
        }
        return absl::OkStatus();
    }
    if (request.has_opening()) {
        return absl::InvalidArgumentError(
            "opening: only with a scan; a mesh alone has its corners in mesh.corners");
    }
    if (request.additional_scans_size() > 0) {
        return absl::InvalidArgumentError(
            "additional_scans: need a first empty scan (scan) to be aligned to");
    }
    return absl::OkStatus();
}

/// The figures of a container that its warnings come from, as core keeps them.
model::ContainerModel CapacityFiguresOf(const v1::Container& container) {
    model::ContainerModel figures;
    figures.struck_capacity_m3 = container.struck_capacity_m3();
    figures.struck_capacity_sigma_m3 = container.struck_capacity_uncertainty_m3();
    for (const v1::UnseenSide& side : container.unseen_sides()) {
        figures.unseen.push_back(
            {side.from_corner(), side.to_corner(), side.area_m2(), side.uncertainty_m3()});
    }
    return figures;
}

}  // namespace

void SoilVolumeHandlers::AddWarnings(v1::Container* container) const {
    container->clear_warnings();
    for (std::string& warning : pipeline::CapacityWarnings(CapacityFiguresOf(*container),
                                                           options_.capacity_warning_share)) {
        container->add_warnings(std::move(warning));
    }
}

absl::StatusOr<std::vector<pipeline::EmptyScan>> SoilVolumeHandlers::DecodeEmptyScans(
    const v1::RegisterContainerRequest& request, const Scan& first, std::size_t max_scans,
    CallRecord& record) const {
    if (static_cast<std::size_t>(request.additional_scans_size()) + 1 > max_scans) {
        return absl::InvalidArgumentError(absl::StrCat("additional_scans: at most ", max_scans - 1,
                                                       " (got ", request.additional_scans_size(),
                                                       ")"));
    }
    std::vector<pipeline::EmptyScan> scans = {{first.cloud, std::nullopt, first.more_sensors}};
    for (int i = 0; i < request.additional_scans_size(); ++i) {
        const v1::EmptyScan& extra = request.additional_scans(i);
        const std::string field = absl::StrCat("additional_scans[", i, "]");
        SOILVOL_ASSIGN_OR_RETURN(const Scan decoded, DecodeScan(extra.scan(), "", record));
        if (decoded.calibration != nullptr) {
            return absl::InvalidArgumentError(absl::StrCat(field, ".scan: must be a point cloud"));
        }
        pipeline::EmptyScan scan{decoded.cloud, std::nullopt, decoded.more_sensors};
        if (extra.has_opening()) {
            auto marks = ToOpeningMarks(extra.opening(), false);
            if (!marks.ok()) {
                return absl::InvalidArgumentError(
                    absl::StrCat(field, ".", marks.status().message()));
            }
            scan.corners = std::get<Corners>(*marks);
        }
        scans.push_back(std::move(scan));
    }
    return scans;
}

absl::StatusOr<model::ContainerModel> SoilVolumeHandlers::BuildModel(
    const v1::RegisterContainerRequest& request, const model::ModelConfig& config,
    v1::Container* response, CallRecord& record) const {
    if (request.has_mesh()) return BuildMeshModel(request, config, response, record);
    SOILVOL_ASSIGN_OR_RETURN(const Scan scan, DecodeScan(request.scan(), "", record));
    if (scan.calibration != nullptr && request.additional_scans_size() > 0) {
        return absl::InvalidArgumentError(
            "additional_scans: only point-cloud registrations fuse several scans");
    }
    SOILVOL_ASSIGN_OR_RETURN(const pipeline::OpeningMarks marks,
                             ToOpeningMarks(request.opening(), scan.calibration != nullptr));
    if (scan.calibration != nullptr) {
        absl::StatusOr<pipeline::StereoModel> stereo = pipeline::BuildStereoContainerModel(
            *scan.calibration->stereo, {scan.left, scan.right}, marks, config, {}, record.stop);
        if (!stereo.ok()) return stereo.status();
        record.stages_ms.push_back({"match", stereo->timings.match_ms});
        response->set_registered_from(v1::SCAN_KIND_STEREO);
        response->set_calibration_id(scan.calibration->info.calibration_id());
        return std::move(stereo->model);
    }
    pipeline::RegistrationConfig registration;
    registration.model = config;
    SOILVOL_ASSIGN_OR_RETURN(std::vector<pipeline::EmptyScan> scans,
                             DecodeEmptyScans(request, scan, registration.max_scans, record));
    absl::StatusOr<pipeline::Registration> registered =
        pipeline::RegisterContainer(std::get<Corners>(marks), scans, registration, record.stop);
    if (!registered.ok()) return registered.status();
    response->set_registered_from(request.scan().has_depth() ? v1::SCAN_KIND_DEPTH
                                                             : v1::SCAN_KIND_CLOUD);
    return std::move(registered->model);
}

absl::StatusOr<model::ContainerModel> SoilVolumeHandlers::BuildMeshModel(
    const v1::RegisterContainerRequest& request, const model::ModelConfig& config,
    v1::Container* response, CallRecord& record) const {
    const bool with_scan = request.has_scan();
    SOILVOL_ASSIGN_OR_RETURN(const MeshRequest mesh,
                             ToMeshRequest(request.mesh(), with_scan, options_.mesh_budget));
    record.stages_ms.push_back({"decode", mesh.decode_ms});
    pipeline::RegistrationConfig registration;
    registration.model = config;
    registration.max_capacity_sigma_share = options_.capacity_warning_share;
    Corners corners{};
    std::vector<pipeline::EmptyScan> scans;
    if (with_scan) {
        SOILVOL_ASSIGN_OR_RETURN(const Scan scan, DecodeScan(request.scan(), "", record));
        SOILVOL_ASSIGN_OR_RETURN(const pipeline::OpeningMarks marks,
                                 ToOpeningMarks(request.opening(), false));
        corners = std::get<Corners>(marks);
        SOILVOL_ASSIGN_OR_RETURN(scans,
                                 DecodeEmptyScans(request, scan, registration.max_scans, record));
    }
    absl::StatusOr<pipeline::Registration> registered =
        pipeline::RegisterWithMesh(mesh.input, corners, scans, mesh.T_scan_mesh, mesh.range_noise_m,
                                   registration, record.stop);
    if (!registered.ok()) return MeshStatus(registered.status(), with_scan);
    response->set_registered_from(with_scan ? v1::SCAN_KIND_CLOUD : v1::SCAN_KIND_MESH);
    return std::move(registered->model);
}

absl::Status SoilVolumeHandlers::RegisterContainer(const v1::RegisterContainerRequest& request,
                                                   v1::Container* response, CallRecord& record) {
    const Create create{EntryKind::kContainer, request.container_id(), "container_id",
                        request.overwrite(),   request.etag(),         request.request_id()};
    bool replayed = false;
    SOILVOL_ASSIGN_OR_RETURN(const std::string id, ClaimId(create, response, &replayed));
    record.ids.push_back({"container", id});
    if (!replayed) {
        SOILVOL_RETURN_IF_ERROR(CheckSources(request));
        SOILVOL_ASSIGN_OR_RETURN(const model::ModelConfig config, ModelConfigFor(request));
        SOILVOL_RETURN_IF_ERROR(ApplySettings(request, response));
        Timer timer;
        SOILVOL_ASSIGN_OR_RETURN(const model::ContainerModel model,
                                 BuildModel(request, config, response, record));
        record.stages_ms.push_back({"register", timer.Lap()});
        ToProto(model, response);
        response->set_container_id(id);
        response->set_registration_id(NewEtag());  // 64 random bits, as an etag
        if (request.has_max_range_m()) response->set_max_range_m(request.max_range_m());
        *response->mutable_create_time() = NowTimestamp();
        *response->mutable_update_time() = response->create_time();
        SOILVOL_RETURN_IF_ERROR(record.stop.Check("registration, before storing it"));
        SOILVOL_RETURN_IF_ERROR(Store(create, id, response, model::EncodeModel(model)));
    }
    AddWarnings(response);
    return absl::OkStatus();
}

}  // namespace soilvol::server

namespace soilvol::server {
namespace {

/// The update's fields (by `mask`) merged into `container`, which gets a new etag and update
/// time; InvalidArgument for settings out of range.
absl::Status MergeUpdate(const v1::UpdateContainerRequest& request,
                         const google::protobuf::FieldMask& mask, v1::Container* container) {
    const std::string id = container->container_id();
    google::protobuf::util::FieldMaskUtil::MergeOptions replace;
    replace.set_replace_message_fields(true);   // "material" names the whole message
    replace.set_replace_repeated_fields(true);  // and "labels" the whole map
    google::protobuf::util::FieldMaskUtil::MergeMessageTo(request.container(), mask, replace,
                                                          container);
    SOILVOL_RETURN_IF_ERROR(CheckSettings(*container, "container."));
    container->set_container_id(id);
    container->set_etag(NewEtag());
    *container->mutable_update_time() = NowTimestamp();
    container->clear_warnings();  // output only, never stored
    return absl::OkStatus();
}

}  // namespace

absl::Status SoilVolumeHandlers::UpdateContainer(const v1::UpdateContainerRequest& request,
                                                 v1::Container* response, CallRecord& record) {
    const std::string& id = request.container().container_id();
    record.ids.push_back({"container", id});
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, "container.container_id"));
    SOILVOL_ASSIGN_OR_RETURN(const google::protobuf::FieldMask mask, UpdateMaskOf(request));
    // Read, merge, write only if the entry is still the one read: a concurrent update in
    // between is never lost. Without a client etag the merge is tried again on the new entry;
    // with one, the client's view is stale (ABORTED).
    constexpr int kAttempts = 8;
    absl::Status written;
    for (int attempt = 0; attempt < kAttempts; ++attempt) {
        absl::StatusOr<StoredEntry> entry = store_.Get(EntryKind::kContainer, id);
        if (!entry.ok()) return Annotate(entry.status(), "container.container_id");
        response->Clear();
        std::string_view model;
        SOILVOL_RETURN_IF_ERROR(DecodeStoredRecord(entry->payload, response, &model));
        const std::string read_etag =
            response->etag().empty() ? EtagOf(entry->payload) : response->etag();
        SOILVOL_RETURN_IF_ERROR(
            CheckEtag(request.container().etag(), read_etag, absl::StrCat("'", id, "'")));
        SOILVOL_RETURN_IF_ERROR(MergeUpdate(request, mask, response));
        written =
            store_.PutIf(EntryKind::kContainer, id, EncodeStoredRecord(*response, model),
                         EtagIs(EntryKind::kContainer, id, read_etag, "container.container_id"));
        if (!absl::IsAborted(written) || !request.container().etag().empty()) break;
    }
    SOILVOL_RETURN_IF_ERROR(written);
    AddWarnings(response);
    return absl::OkStatus();
}

}  // namespace soilvol::server
