#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/model/model_codec.hpp"
#include "google/protobuf/util/time_util.h"
#include "server/proto_convert.hpp"
#include "server/soilvol_handlers.hpp"
#include "server/status_map.hpp"
#include "server/stored_record.hpp"

namespace soilvol::server {
namespace {

constexpr double kMaxRangeLimitM = 1000.0;

}  // namespace

absl::Status SoilVolumeHandlers::RegisterContainer(const v1::RegisterContainerRequest& request,
                                                   v1::Container* response, CallRecord& record) {
    SOILVOL_ASSIGN_OR_RETURN(const std::string id,
                             ClaimId(EntryKind::kContainer, request.container_id(), "container_id",
                                     request.overwrite()));
    record.ids.push_back({"container", id});
    if (!request.has_opening()) {
        return absl::InvalidArgumentError("opening: is required (corners or pixel_corners)");
    }
    model::ModelConfig config;
    if (request.has_max_range_m()) {
        const double range = request.max_range_m();
        if (!std::isfinite(range) || range <= 0.0 || range > kMaxRangeLimitM) {
            return absl::InvalidArgumentError(
                absl::StrCat("max_range_m: must be in (0, ", kMaxRangeLimitM, "] metres"));
        }
        config.preprocess.max_range_m = range;
    }
    SOILVOL_ASSIGN_OR_RETURN(const Scan scan, DecodeScan(request.scan(), "", record));
    SOILVOL_ASSIGN_OR_RETURN(const pipeline::OpeningMarks marks,
                             ToOpeningMarks(request.opening(), scan.calibration != nullptr));

    Timer timer;
    absl::StatusOr<model::ContainerModel> model;
    if (scan.calibration != nullptr) {
        absl::StatusOr<pipeline::StereoModel> stereo = pipeline::BuildStereoContainerModel(
            *scan.calibration->stereo, {scan.left, scan.right}, marks, config);
        if (!stereo.ok()) return stereo.status();
        record.stages_ms.push_back({"match", stereo->timings.match_ms});
        model = std::move(stereo->model);
        response->set_registered_from(v1::SCAN_KIND_STEREO);
        response->set_calibration_id(scan.calibration->info.calibration_id());
    } else {
        model = model::BuildContainerModel(scan.cloud, std::get<Corners>(marks), config);
        response->set_registered_from(v1::SCAN_KIND_CLOUD);
    }
    if (!model.ok()) return model.status();
    record.stages_ms.push_back({"register", timer.Lap()});

    ToProto(*model, response);
    response->set_container_id(id);
    if (request.has_max_range_m()) response->set_max_range_m(request.max_range_m());
    *response->mutable_create_time() = google::protobuf::util::TimeUtil::GetCurrentTime();
    return store_.Put(EntryKind::kContainer, id,
                      EncodeStoredRecord(*response, model::EncodeModel(*model)),
                      request.overwrite());
}

}  // namespace soilvol::server
