#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/model/model_codec.hpp"
#include "core/pipeline/registration.hpp"
#include "google/protobuf/util/time_util.h"
#include "server/proto_convert.hpp"
#include "server/soilvol_handlers.hpp"
#include "server/status_map.hpp"
#include "server/stored_record.hpp"

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

}  // namespace

absl::StatusOr<std::vector<pipeline::EmptyScan>> SoilVolumeHandlers::DecodeEmptyScans(
    const v1::RegisterContainerRequest& request, const Cloud& first, std::size_t max_scans,
    CallRecord& record) const {
    if (static_cast<std::size_t>(request.additional_scans_size()) + 1 > max_scans) {
        return absl::InvalidArgumentError(absl::StrCat("additional_scans: at most ", max_scans - 1,
                                                       " (got ", request.additional_scans_size(),
                                                       ")"));
    }
    std::vector<pipeline::EmptyScan> scans = {{first, std::nullopt}};
    for (int i = 0; i < request.additional_scans_size(); ++i) {
        const v1::EmptyScan& extra = request.additional_scans(i);
        const std::string field = absl::StrCat("additional_scans[", i, "]");
        SOILVOL_ASSIGN_OR_RETURN(const Scan decoded, DecodeScan(extra.scan(), "", record));
        if (decoded.calibration != nullptr) {
            return absl::InvalidArgumentError(absl::StrCat(field, ".scan: must be a point cloud"));
        }
        pipeline::EmptyScan scan{decoded.cloud, std::nullopt};
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
    const v1::RegisterContainerRequest& request, const Scan& scan, const model::ModelConfig& config,
    v1::Container* response, CallRecord& record) const {
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
                             DecodeEmptyScans(request, scan.cloud, registration.max_scans, record));
    absl::StatusOr<pipeline::Registration> registered =
        pipeline::RegisterContainer(std::get<Corners>(marks), scans, registration, record.stop);
    if (!registered.ok()) return registered.status();
    response->set_registered_from(v1::SCAN_KIND_CLOUD);
    return std::move(registered->model);
}

absl::Status SoilVolumeHandlers::RegisterContainer(const v1::RegisterContainerRequest& request,
                                                   v1::Container* response, CallRecord& record) {
    const Create create{EntryKind::kContainer, request.container_id(), "container_id",
                        request.overwrite(),   request.etag(),         request.request_id()};
    bool replayed = false;
    SOILVOL_ASSIGN_OR_RETURN(const std::string id, ClaimId(create, response, &replayed));
    record.ids.push_back({"container", id});
    if (replayed) return absl::OkStatus();
    if (!request.has_opening()) {
        return absl::InvalidArgumentError("opening: is required (corners or pixel_corners)");
    }
    SOILVOL_ASSIGN_OR_RETURN(const model::ModelConfig config, ModelConfigFor(request));
    SOILVOL_ASSIGN_OR_RETURN(const Scan scan, DecodeScan(request.scan(), "", record));
    Timer timer;
    absl::StatusOr<model::ContainerModel> model =
        BuildModel(request, scan, config, response, record);
    if (!model.ok()) return model.status();
    record.stages_ms.push_back({"register", timer.Lap()});

    ToProto(*model, response);
    response->set_container_id(id);
    if (request.has_max_range_m()) response->set_max_range_m(request.max_range_m());
    *response->mutable_create_time() = google::protobuf::util::TimeUtil::GetCurrentTime();
    SOILVOL_RETURN_IF_ERROR(record.stop.Check("registration, before storing it"));
    return Store(create, id, response, model::EncodeModel(*model));
}

}  // namespace soilvol::server
