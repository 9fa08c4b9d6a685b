#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "core/pipeline/estimate_policy.hpp"
#include "core/volume/load_status.hpp"
#include "proto/convert/proto_convert.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/handlers/soilvol_handlers.hpp"

namespace soilvol::server {
namespace {

v1::EstimationMethod MethodOf(volume::Method method) {
    switch (method) {
        case volume::Method::kHeightmap:
            return v1::ESTIMATION_METHOD_HEIGHTMAP;
        case volume::Method::kPaper:
            return v1::ESTIMATION_METHOD_PAPER;
    }
    return v1::ESTIMATION_METHOD_UNSPECIFIED;
}

/// What a container's estimates take: a mesh alone places the container before a cloud sensor.
pipeline::ScanKind KindOf(v1::ScanKind kind) {
    switch (kind) {
        case v1::SCAN_KIND_STEREO:
            return pipeline::ScanKind::kStereo;
        case v1::SCAN_KIND_DEPTH:
            return pipeline::ScanKind::kDepth;
        case v1::SCAN_KIND_UNSPECIFIED:
        case v1::SCAN_KIND_CLOUD:
        case v1::SCAN_KIND_MESH:
        default:
            return pipeline::ScanKind::kCloud;
    }
}

/// What a scan is (its source must be set).
pipeline::ScanKind ScanKindOf(const v1::Scan& scan) {
    switch (scan.source_case()) {
        case v1::Scan::kStereo:
            return pipeline::ScanKind::kStereo;
        case v1::Scan::kDepth:
            return pipeline::ScanKind::kDepth;
        case v1::Scan::kCloud:
        case v1::Scan::SOURCE_NOT_SET:
            break;
    }
    return pipeline::ScanKind::kCloud;
}

/// The request's options for core, which checks them against the container.
absl::StatusOr<pipeline::EstimateRequest> EstimateRequestOf(
    const v1::EstimateVolumeRequest& request, const v1::Container& container) {
    pipeline::EstimateRequest out;
    switch (request.method()) {
        case v1::ESTIMATION_METHOD_UNSPECIFIED:
        case v1::ESTIMATION_METHOD_HEIGHTMAP:
            out.method = volume::Method::kHeightmap;
            break;
        case v1::ESTIMATION_METHOD_PAPER:
            out.method = volume::Method::kPaper;
            break;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat("method: unknown value ", static_cast<int>(request.method())));
    }
    if (request.has_grid_cell_m()) out.grid_cell_m = request.grid_cell_m();
    if (request.has_material_density_kg_m3()) {
        out.material_density_kg_m3 = request.material_density_kg_m3();
    }
    if (request.has_container_pose()) {
        const v1::KinematicPose& kinematic = request.container_pose();
        SOILVOL_ASSIGN_OR_RETURN(out.kinematic_pose,
                                 ToPose(kinematic.pose(), "container_pose.pose"));
        out.kinematic_position_sigma_m = kinematic.position_sigma_m();
        out.kinematic_orientation_sigma_deg = kinematic.orientation_sigma_deg();
    }
    if (container.has_max_range_m()) out.max_range_m = container.max_range_m();
    return out;
}

/// The model lives in the frame of the sensor it was registered from (core's rule).
absl::Status CheckSameSensor(const v1::Scan& scan, const v1::Container& container) {
    if (scan.source_case() == v1::Scan::SOURCE_NOT_SET) return absl::OkStatus();  // DecodeScan's
    return pipeline::CheckSameSensor(container.container_id(), KindOf(container.registered_from()),
                                     container.calibration_id(), ScanKindOf(scan),
                                     scan.stereo().calibration_id());
}

/// Queue and total time into the response, every stage that ran into the call's record.
void RecordTimings(CallRecord& record, double handler_ms, v1::Timings* timings) {
    timings->set_queue_ms(record.queue_ms);
    timings->set_total_ms(record.queue_ms + handler_ms);
    for (const auto& [stage, ms] : {std::pair<const char*, double>{"decode", timings->decode_ms()},
                                    {"rectify", timings->rectify_ms()},
                                    {"match", timings->match_ms()},
                                    {"reproject", timings->reproject_ms()},
                                    {"preprocess", timings->preprocess_ms()},
                                    {"align", timings->align_ms()},
                                    {"volume", timings->volume_ms()}}) {
        if (ms > 0.0) record.stages_ms.push_back({stage, ms});
    }
}

// The load status as /metrics labels it.
const char* LoadStatusLabel(volume::LoadStatus status) {
    switch (status) {
        case volume::LoadStatus::kEmpty:
            return "empty";
        case volume::LoadStatus::kCarryback:
            return "carryback";
        case volume::LoadStatus::kUnderloaded:
            return "underloaded";
        case volume::LoadStatus::kLoadedOk:
            return "loaded_ok";
        case volume::LoadStatus::kOverloaded:
            return "overloaded";
        case volume::LoadStatus::kLoaded:
            return "loaded";
    }
    return "loaded";
}

/// What an answered estimate adds to production.
Measures MeasuresOf(const v1::EstimateVolumeResponse& response, const v1::Material& material) {
    Measures measures;
    measures.volume_m3 = response.volume_m3();
    measures.bank_volume_m3 = response.load().bank_volume_m3();
    if (response.has_mass_kg()) measures.mass_kg = response.mass_kg();
    measures.fill_ratio = response.fill_ratio();
    measures.load_status = response.load().status();
    measures.material = material.name();
    return measures;
}

}  // namespace

absl::StatusOr<pipeline::VolumeEstimate> SoilVolumeHandlers::RunEstimate(
    const ContainerEntry& container, const Scan& scan, const pipeline::EstimateConfig& config,
    v1::Timings* timings, const StopToken& stop) const {
    if (scan.calibration == nullptr) {
        timings->set_decode_ms(scan.decode_ms);
        return pipeline::EstimateVolume(container.model, scan.cloud, scan.more_sensors, config,
                                        stop);
    }
    pipeline::StereoEstimateConfig stereo_config;
    stereo_config.estimate = config;
    // A StatusOr kept whole: GCC 12 misreads the moved-out optional as uninitialized.
    absl::StatusOr<pipeline::StereoEstimate> stereo = pipeline::EstimateVolumeStereo(
        container.model, *scan.calibration->stereo, {scan.left, scan.right}, stereo_config, stop);
    if (!stereo.ok()) return stereo.status();
    timings->set_decode_ms(stereo->stereo.decode_ms);
    timings->set_rectify_ms(stereo->stereo.rectify_ms);
    timings->set_match_ms(stereo->stereo.match_ms);
    timings->set_reproject_ms(stereo->stereo.reproject_ms);
    return std::move(stereo->estimate);
}

absl::Status SoilVolumeHandlers::EstimateVolume(const v1::EstimateVolumeRequest& request,
                                                v1::EstimateVolumeResponse* response,
                                                CallRecord& record) {
    Timer timer;
    record.ids.push_back({"container", request.container_id()});
    if (!request.request_id().empty()) record.ids.push_back({"request", request.request_id()});
    SOILVOL_ASSIGN_OR_RETURN(auto container, LoadContainer(request.container_id(), "container_id"));
    SOILVOL_ASSIGN_OR_RETURN(const pipeline::EstimateRequest options,
                             EstimateRequestOf(request, container->info));
    SOILVOL_ASSIGN_OR_RETURN(const pipeline::EstimateConfig config,
                             pipeline::ConfigureEstimate(options, container->model));
    SOILVOL_RETURN_IF_ERROR(CheckSameSensor(request.scan(), container->info));
    SOILVOL_ASSIGN_OR_RETURN(std::optional<LoadLink> load_link, LoadLinkOf(request, response));
    SOILVOL_ASSIGN_OR_RETURN(const LoadRules rules, ToLoadRules(container->info.material(),
                                                                container->info.load_targets()));
    SOILVOL_ASSIGN_OR_RETURN(const Scan scan,
                             DecodeScan(request.scan(), container->info.calibration_id(), record));
    absl::StatusOr<pipeline::VolumeEstimate> run =
        RunEstimate(*container, scan, config, response->mutable_timings(), record.stop);
    if (!run.ok()) {
        CountRefusal(request, container->info, run.status());
        return run.status();
    }
    const pipeline::VolumeEstimate& estimate = *run;

    ToProto(estimate, response);
    if (scan.depth_counts) {
        ToProto(*scan.depth_counts, scan.depth_points, response->mutable_depth_pixels());
    }
    response->mutable_coverage()->set_capacity_uncertainty_m3(
        container->model.struck_capacity_sigma_m3);
    // The record keeps the heightmap even when the answer omits it.
    if (Records(request) || !request.omit_heightmap()) {
        ToProto(estimate.volume, response->mutable_heightmap());
    }
    response->set_container_id(request.container_id());
    response->set_request_id(request.request_id());
    response->set_registration_id(container->info.registration_id());
    response->set_method(MethodOf(config.method));
    const volume::LoadAssessment load =
        volume::AssessLoad(estimate.volume_m3, estimate.uncertainty_m3, rules.material,
                           rules.targets, options.material_density_kg_m3);
    ToProto(load, response->mutable_load());
    if (load.mass_kg) response->set_mass_kg(*load.mass_kg);
    RecordTimings(record, timer.Lap(), response->mutable_timings());
    record.volume_m3 = estimate.volume_m3;
    record.measured = CallRecord::Measured{
        request.container_id(), LoadStatusLabel(load.status), response->load().bank_volume_m3(),
        response->has_mass_kg() ? std::optional<double>(response->mass_kg()) : std::nullopt};
    for (v1::Alert& alert :
         EstimateAlerts(RulesFor(&container->info, options_.alert_rules), *response, NowMicros())) {
        *response->add_alerts() = std::move(alert);
    }
    RecordEstimate(request, response, std::move(load_link),
                   MeasuresOf(*response, container->info.material()), record);
    if (request.omit_heightmap()) response->clear_heightmap();
    return absl::OkStatus();
}

}  // namespace soilvol::server
