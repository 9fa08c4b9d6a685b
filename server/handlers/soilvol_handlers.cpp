#include "server/handlers/soilvol_handlers.hpp"

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/cloud/sensor_frame.hpp"
#include "core/common/build_info.hpp"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/io/cloud_codec.hpp"
#include "core/model/model_codec.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"
#include "server/handlers/resource_rules.hpp"
#include "server/handlers/sensor_part.hpp"
#include "server/handlers/stored_record.hpp"
#include "server/store/entry_id.hpp"

namespace soilvol::server {
namespace {

/// The prefix of an id the server chooses: "cal-..." or "ctr-...".
const char* IdPrefix(EntryKind kind) {
    switch (kind) {
        case EntryKind::kCalibration:
            return "cal";
        case EntryKind::kContainer:
            return "ctr";
    }
    return "id";
}

const google::protobuf::FieldDescriptor& Field(const google::protobuf::Message& message,
                                               const char* name) {
    return *message.GetDescriptor()->FindFieldByName(name);
}

std::string StringField(const google::protobuf::Message& message, const char* name) {
    return message.GetReflection()->GetString(message, &Field(message, name));
}

void SetStringField(google::protobuf::Message* message, const char* name, std::string value) {
    message->GetReflection()->SetString(message, &Field(*message, name), std::move(value));
}

/// One page of the readable entries of `kind` through `load`; the others as unreadable with
/// the reason. Entries deleted between listing and loading are left out.
template <typename Request, typename Response, typename Load, typename Infos>
absl::Status ListEntries(const EntryStore& store, EntryKind kind, const Request& request,
                         Response* response, Load load, Infos* infos) {
    SOILVOL_ASSIGN_OR_RETURN(Page page,
                             PageOf(store.List(kind), request.page_size(), request.page_token()));
    response->set_next_page_token(page.next_page_token);
    for (const std::string& id : page.ids) {
        auto entry = load(id);
        if (entry.ok()) {
            *infos->Add() = (*entry)->info;
        } else if (!absl::IsNotFound(entry.status())) {
            v1::UnreadableEntry* bad = response->add_unreadable();
            bad->set_id(id);
            bad->set_reason(std::string(entry.status().message()));
        }
    }
    return absl::OkStatus();
}

std::unique_ptr<google::protobuf::Message> NewInfo(EntryKind kind) {
    switch (kind) {
        case EntryKind::kCalibration:
            return std::make_unique<v1::Calibration>();
        case EntryKind::kContainer:
            return std::make_unique<v1::Container>();
    }
    return nullptr;
}

/// The etag of a stored entry: its info's, or for entries written before etags, one from its
/// bytes (as ReadInfo reports it).
absl::StatusOr<std::string> StoredEtag(EntryKind kind, const std::string& payload) {
    std::unique_ptr<google::protobuf::Message> info = NewInfo(kind);
    std::string_view body;
    SOILVOL_RETURN_IF_ERROR(DecodeStoredRecord(payload, info.get(), &body));
    const std::string etag = StringField(*info, "etag");
    return etag.empty() ? EtagOf(payload) : etag;
}

}  // namespace

EntryStore::Precondition EtagIs(EntryKind kind, const std::string& id, const std::string& etag,
                                const char* field) {
    return [kind, id, etag, field](const absl::StatusOr<StoredEntry>& current) -> absl::Status {
        if (!current.ok()) return Annotate(current.status(), field);
        absl::StatusOr<std::string> stored = StoredEtag(kind, current->payload);
        if (!stored.ok()) return Annotate(stored.status(), field);
        return CheckEtag(etag, *stored, absl::StrCat("'", id, "'"));
    };
}

SoilVolumeHandlers::SoilVolumeHandlers(EntryStore& store, EstimateRecorder* recorder,
                                       EstimateFeed* feed, AlertFeed* alert_feed,
                                       LoadEventFeed* load_feed, HandlerOptions options)
    : store_(store),
      options_(std::move(options)),
      recorder_(recorder),
      feed_(feed),
      alert_feed_(alert_feed),
      load_feed_(load_feed),
      start_time_(NowTimestamp()),
      calibrations_(store, &DecodeCalibration),
      containers_(store, &DecodeContainer) {}

absl::StatusOr<SoilVolumeHandlers::CalibrationEntry> SoilVolumeHandlers::DecodeCalibration(
    const StoredEntry& entry) {
    CalibrationEntry out;
    // The message holds the whole rig; older entries also carry it as OpenCV YAML,
    // which is no longer read (OpenCV's YAML parser hangs on some inputs).
    std::string_view legacy_yaml;
    SOILVOL_RETURN_IF_ERROR(DecodeStoredRecord(entry.payload, &out.info, &legacy_yaml));
    out.info.set_calibration_id(entry.id);
    if (out.info.etag().empty()) out.info.set_etag(EtagOf(entry.payload));
    absl::StatusOr<stereo::StereoCalibration> calibration = ToStereoCalibration(out.info);
    if (!calibration.ok()) {
        return absl::DataLossError(
            absl::StrCat("stored calibration is not usable: ", calibration.status().message()));
    }
    SOILVOL_ASSIGN_OR_RETURN(stereo::StereoReconstructor stereo,
                             stereo::StereoReconstructor::Create(*calibration, {}));
    out.stereo = std::make_shared<const stereo::StereoReconstructor>(std::move(stereo));
    return out;
}

absl::StatusOr<SoilVolumeHandlers::ContainerEntry> SoilVolumeHandlers::DecodeContainer(
    const StoredEntry& entry) {
    ContainerEntry out;
    std::string_view model;
    SOILVOL_RETURN_IF_ERROR(DecodeStoredRecord(entry.payload, &out.info, &model));
    out.info.set_container_id(entry.id);
    if (out.info.etag().empty()) out.info.set_etag(EtagOf(entry.payload));
    SOILVOL_ASSIGN_OR_RETURN(out.model, model::DecodeModel(model));
    return out;
}

absl::StatusOr<std::shared_ptr<const SoilVolumeHandlers::CalibrationEntry>>
SoilVolumeHandlers::LoadCalibration(const std::string& id, const std::string& field) const {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, field));
    auto entry = calibrations_.Get(EntryKind::kCalibration, id);
    if (!entry.ok()) return Annotate(entry.status(), field);
    return *std::move(entry);
}

absl::StatusOr<std::shared_ptr<const SoilVolumeHandlers::ContainerEntry>>
SoilVolumeHandlers::LoadContainer(const std::string& id, const std::string& field) const {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, field));
    auto entry = containers_.Get(EntryKind::kContainer, id);
    if (!entry.ok()) return Annotate(entry.status(), field);
    return *std::move(entry);
}

absl::Status SoilVolumeHandlers::ReadInfo(EntryKind kind, const std::string& id,
                                          google::protobuf::Message* info) const {
    SOILVOL_ASSIGN_OR_RETURN(const StoredEntry entry, store_.Get(kind, id));
    std::string_view body;
    SOILVOL_RETURN_IF_ERROR(DecodeStoredRecord(entry.payload, info, &body));
    if (StringField(*info, "etag").empty()) SetStringField(info, "etag", EtagOf(entry.payload));
    return absl::OkStatus();
}

absl::StatusOr<std::string> SoilVolumeHandlers::ClaimId(const Create& create,
                                                        google::protobuf::Message* stored,
                                                        bool* replayed) const {
    *replayed = false;
    SOILVOL_RETURN_IF_ERROR(ValidateRequestId(create.request_id, "request_id"));
    if (!create.etag.empty() && !create.overwrite) {
        return absl::InvalidArgumentError(
            "etag: only an overwrite can require an etag; set overwrite too");
    }
    std::string id = create.id;
    if (id.empty()) {
        id = ServerChosenId(IdPrefix(create.kind), create.request_id);
    } else {
        SOILVOL_RETURN_IF_ERROR(ValidateId(id, create.id_field));
    }
    if (absl::Status read = ReadInfo(create.kind, id, stored); !read.ok()) {
        stored->Clear();
        // An entry that cannot be read can only be overwritten.
        if (absl::IsNotFound(read) || create.overwrite) return id;
        return Annotate(read, create.id_field);
    }
    if (!create.request_id.empty() &&
        StringField(*stored, "create_request_id") == create.request_id) {
        *replayed = true;
        return id;
    }
    const std::string etag = StringField(*stored, "etag");
    stored->Clear();
    if (!create.overwrite) {
        return absl::AlreadyExistsError(absl::StrCat(
            create.id_field, ": '", id, "' already exists; set overwrite to replace it"));
    }
    SOILVOL_RETURN_IF_ERROR(CheckEtag(create.etag, etag, absl::StrCat("'", id, "'")));
    return id;
}

absl::Status SoilVolumeHandlers::Store(const Create& create, const std::string& id,
                                       google::protobuf::Message* info, std::string_view body) {
    SetStringField(info, "create_request_id", create.request_id);
    SetStringField(info, "etag", NewEtag());
    const std::string payload = EncodeStoredRecord(*info, body);
    // The entry may have changed while this one was computed: the etag is compared again
    // under the store's lock, and the write happens only if it still holds.
    absl::Status put = create.etag.empty()
                           ? store_.Put(create.kind, id, payload, create.overwrite)
                           : store_.PutIf(create.kind, id, payload,
                                          EtagIs(create.kind, id, create.etag, create.id_field));
    if (absl::IsAlreadyExists(put) && !create.request_id.empty()) {
        // A retry of this very request that finished first: its result is the answer.
        std::unique_ptr<google::protobuf::Message> first(info->New());
        if (ReadInfo(create.kind, id, first.get()).ok() &&
            StringField(*first, "create_request_id") == create.request_id) {
            info->CopyFrom(*first);
            return absl::OkStatus();
        }
    }
    return Annotate(put, create.id_field);
}

absl::Status SoilVolumeHandlers::DeleteEntry(EntryKind kind, const std::string& id,
                                             const char* field, const std::string& etag) {
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, field));
    if (etag.empty()) return Annotate(store_.Delete(kind, id), field);
    return Annotate(store_.DeleteIf(kind, id, EtagIs(kind, id, etag, field)), field);
}

absl::StatusOr<SoilVolumeHandlers::Scan> SoilVolumeHandlers::DecodeScan(
    const v1::Scan& scan, const std::string& calibration_id, CallRecord& record) const {
    // Cloud files are parsed here; stereo pairs are decoded by the reconstructor.
    Scan out;
    switch (scan.source_case()) {
        case v1::Scan::kCloud:
        case v1::Scan::kDepth: {
            SOILVOL_ASSIGN_OR_RETURN(
                SensorPart first, scan.has_cloud() ? DecodeCloudPart(scan.cloud(), "scan.cloud")
                                                   : DecodeDepthPart(scan.depth(), "scan.depth"));
            SOILVOL_ASSIGN_OR_RETURN(out.more_sensors, DecodeAdditionalSensors(scan, first));
            out.cloud = std::move(first.points);
            out.decode_ms = first.decode_ms;
            out.dropped_nonfinite = first.dropped_nonfinite;
            out.depth_counts = first.depth_counts;
            out.depth_points = first.depth_points;
            return out;
        }
        case v1::Scan::kStereo: {
            const v1::StereoScan& stereo = scan.stereo();
            if (scan.additional_sensors_size() > 0) {
                return absl::InvalidArgumentError(
                    "scan.additional_sensors: a stereo pair is one sensor; give the other "
                    "sensors' clouds or depth images with a cloud or depth scan");
            }
            if (stereo.left().empty())
                return absl::InvalidArgumentError("scan.stereo.left: is empty");
            if (stereo.right().empty()) {
                return absl::InvalidArgumentError("scan.stereo.right: is empty");
            }
            const std::string& id =
                stereo.calibration_id().empty() ? calibration_id : stereo.calibration_id();
            record.ids.push_back({"calibration", id});
            SOILVOL_ASSIGN_OR_RETURN(out.calibration,
                                     LoadCalibration(id, "scan.stereo.calibration_id"));
            out.left = stereo.left();
            out.right = stereo.right();
            return out;
        }
        default:
            return absl::InvalidArgumentError(
                "scan: is required: give cloud {data}, stereo {left, right, calibration_id} or "
                "depth {depth, camera}");
    }
}

absl::Status SoilVolumeHandlers::GetCalibration(const v1::GetCalibrationRequest& request,
                                                v1::Calibration* response, CallRecord& record) {
    record.ids.push_back({"calibration", request.calibration_id()});
    SOILVOL_ASSIGN_OR_RETURN(auto entry,
                             LoadCalibration(request.calibration_id(), "calibration_id"));
    *response = entry->info;
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::ListCalibrations(const v1::ListCalibrationsRequest& request,
                                                  v1::ListCalibrationsResponse* response,
                                                  CallRecord&) {
    return ListEntries(
        store_, EntryKind::kCalibration, request, response,
        [this](const std::string& id) { return LoadCalibration(id, "id"); },
        response->mutable_calibrations());
}

absl::Status SoilVolumeHandlers::DeleteCalibration(const v1::DeleteCalibrationRequest& request,
                                                   v1::DeleteCalibrationResponse*,
                                                   CallRecord& record) {
    record.ids.push_back({"calibration", request.calibration_id()});
    return DeleteEntry(EntryKind::kCalibration, request.calibration_id(), "calibration_id",
                       request.etag());
}

absl::Status SoilVolumeHandlers::GetContainer(const v1::GetContainerRequest& request,
                                              v1::Container* response, CallRecord& record) {
    record.ids.push_back({"container", request.container_id()});
    SOILVOL_ASSIGN_OR_RETURN(auto entry, LoadContainer(request.container_id(), "container_id"));
    *response = entry->info;
    AddWarnings(response);
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::ListContainers(const v1::ListContainersRequest& request,
                                                v1::ListContainersResponse* response, CallRecord&) {
    SOILVOL_RETURN_IF_ERROR(ListEntries(
        store_, EntryKind::kContainer, request, response,
        [this](const std::string& id) { return LoadContainer(id, "id"); },
        response->mutable_containers()));
    for (v1::Container& container : *response->mutable_containers()) AddWarnings(&container);
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::DeleteContainer(const v1::DeleteContainerRequest& request,
                                                 v1::DeleteContainerResponse*, CallRecord& record) {
    record.ids.push_back({"container", request.container_id()});
    const absl::Status deleted =
        DeleteEntry(EntryKind::kContainer, request.container_id(), "container_id", request.etag());
    // A container already gone still has its records purged (a retry after a failed purge);
    // the answer stays NOT_FOUND.
    const bool purge = request.purge_records() && recorder_ != nullptr &&
                       (deleted.ok() || absl::IsNotFound(deleted));
    if (!purge) return deleted;
    const absl::StatusOr<std::int64_t> purged =
        recorder_->store().DeleteContainer(request.container_id());
    if (!purged.ok()) {
        return absl::UnavailableError(absl::StrCat(
            "container '", request.container_id(),
            "': its estimate records were not purged (retry: a deleted container's records are "
            "purged too): ",
            purged.status().message()));
    }
    if (!deleted.ok()) return deleted;
    record.ids.push_back({"purged_records", absl::StrCat(*purged)});
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::GetServerInfo(const v1::GetServerInfoRequest&,
                                               v1::ServerInfo* response, CallRecord&) {
    const BuildInfo& build = GetBuildInfo();
    response->set_version(build.version);
    response->set_revision(build.revision);
    response->set_build_type(build.build_type);
    response->set_compiler(build.compiler);
    for (const auto& [name, version] : build.libraries) {
        (*response->mutable_libraries())[name] = version;
    }
    response->set_api(v1::ServerInfo::descriptor()->file()->service(0)->full_name());
    *response->mutable_start_time() = start_time_;
    return absl::OkStatus();
}

}  // namespace soilvol::server
