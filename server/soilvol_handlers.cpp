#include "server/soilvol_handlers.hpp"

#include <random>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/io/cloud_codec.hpp"
#include "core/model/model_codec.hpp"
#include "server/proto_convert.hpp"
#include "server/status_map.hpp"
#include "server/store/entry_id.hpp"
#include "server/stored_record.hpp"

namespace soilvol::server {
namespace {

std::string NewId(std::string_view prefix) {
    static thread_local std::mt19937_64 rng(std::random_device{}());
    return absl::StrFormat("%s-%012x", prefix, rng() & 0xffffffffffffULL);
}

/// Every readable entry of `kind` through `load`; the others as unreadable with the reason.
/// Entries deleted between listing and loading are left out.
template <typename Load, typename Infos>
void ListEntries(const EntryStore& store, EntryKind kind, Load load, Infos* infos,
                 google::protobuf::RepeatedPtrField<v1::UnreadableEntry>* unreadable) {
    for (const std::string& id : store.List(kind)) {
        auto entry = load(id);
        if (entry.ok()) {
            *infos->Add() = (*entry)->info;
        } else if (!absl::IsNotFound(entry.status())) {
            v1::UnreadableEntry* bad = unreadable->Add();
            bad->set_id(id);
            bad->set_reason(std::string(entry.status().message()));
        }
    }
}

}  // namespace

SoilVolumeHandlers::SoilVolumeHandlers(EntryStore& store)
    : store_(store),
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

absl::StatusOr<std::string> SoilVolumeHandlers::ClaimId(EntryKind kind, const std::string& id,
                                                        const std::string& field,
                                                        bool overwrite) const {
    if (id.empty()) return NewId(kind == EntryKind::kCalibration ? "cal" : "ctr");
    SOILVOL_RETURN_IF_ERROR(ValidateId(id, field));
    if (!overwrite && store_.Stat(kind, id).ok()) {
        return absl::AlreadyExistsError(
            absl::StrCat(field, ": '", id, "' already exists; set overwrite to replace it"));
    }
    return id;
}

absl::StatusOr<SoilVolumeHandlers::Scan> SoilVolumeHandlers::DecodeScan(
    const v1::Scan& scan, const std::string& calibration_id, CallRecord& record) const {
    // Cloud files are parsed here; stereo pairs are decoded by the reconstructor.
    Scan out;
    switch (scan.source_case()) {
        case v1::Scan::kCloud: {
            Timer timer;
            absl::StatusOr<io::DecodedCloud> cloud = io::DecodeCloud(scan.cloud().data());
            if (!cloud.ok()) return Annotate(cloud.status(), "scan.cloud.data");
            out.decode_ms = timer.Lap();
            out.cloud = std::move(cloud->points);
            out.dropped_nonfinite = cloud->dropped_nonfinite;
            return out;
        }
        case v1::Scan::kStereo: {
            const v1::StereoScan& stereo = scan.stereo();
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
                "scan: is required: give cloud {data} or stereo {left, right, calibration_id}");
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

absl::Status SoilVolumeHandlers::ListCalibrations(const v1::ListCalibrationsRequest&,
                                                  v1::ListCalibrationsResponse* response,
                                                  CallRecord&) {
    ListEntries(
        store_, EntryKind::kCalibration,
        [this](const std::string& id) { return LoadCalibration(id, "id"); },
        response->mutable_calibrations(), response->mutable_unreadable());
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::DeleteCalibration(const v1::DeleteCalibrationRequest& request,
                                                   v1::DeleteCalibrationResponse*,
                                                   CallRecord& record) {
    record.ids.push_back({"calibration", request.calibration_id()});
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.calibration_id(), "calibration_id"));
    return Annotate(store_.Delete(EntryKind::kCalibration, request.calibration_id()),
                    "calibration_id");
}

absl::Status SoilVolumeHandlers::GetContainer(const v1::GetContainerRequest& request,
                                              v1::Container* response, CallRecord& record) {
    record.ids.push_back({"container", request.container_id()});
    SOILVOL_ASSIGN_OR_RETURN(auto entry, LoadContainer(request.container_id(), "container_id"));
    *response = entry->info;
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::ListContainers(const v1::ListContainersRequest&,
                                                v1::ListContainersResponse* response, CallRecord&) {
    ListEntries(
        store_, EntryKind::kContainer,
        [this](const std::string& id) { return LoadContainer(id, "id"); },
        response->mutable_containers(), response->mutable_unreadable());
    return absl::OkStatus();
}

absl::Status SoilVolumeHandlers::DeleteContainer(const v1::DeleteContainerRequest& request,
                                                 v1::DeleteContainerResponse*, CallRecord& record) {
    record.ids.push_back({"container", request.container_id()});
    SOILVOL_RETURN_IF_ERROR(ValidateId(request.container_id(), "container_id"));
    return Annotate(store_.Delete(EntryKind::kContainer, request.container_id()), "container_id");
}

}  // namespace soilvol::server
