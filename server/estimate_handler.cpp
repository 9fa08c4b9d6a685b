#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "server/proto_convert.hpp"
#include "server/soilvol_handlers.hpp"

namespace soilvol::server {
namespace {

constexpr double kMinCellM = 0.005;
constexpr double kMaxCellM = 2.0;
constexpr double kMaxDensityKgM3 = 30000.0;
constexpr double kPaperMinPointsPerCell = 4.0;

/// The engine settings a request asks for, checked against the container.
absl::StatusOr<pipeline::EstimateConfig> EstimateConfigFor(const v1::EstimateVolumeRequest& request,
                                                           const v1::Container& container,
                                                           const model::ContainerModel& model) {
    pipeline::EstimateConfig config;
    switch (request.method()) {
        case v1::ESTIMATION_METHOD_UNSPECIFIED:
        case v1::ESTIMATION_METHOD_HEIGHTMAP:
            config.method = volume::Method::kHeightmap;
            break;
        case v1::ESTIMATION_METHOD_PAPER:
            config.method = volume::Method::kPaper;
            break;
        default:
            return absl::InvalidArgumentError(
                absl::StrCat("method: unknown value ", static_cast<int>(request.method())));
    }
    if (request.has_grid_cell_m()) {
        const double cell = request.grid_cell_m();
        if (!std::isfinite(cell) || cell < kMinCellM || cell > kMaxCellM) {
            return absl::InvalidArgumentError(
                absl::StrCat("grid_cell_m: must be in [", kMinCellM, ", ", kMaxCellM, "] metres"));
        }
        const double cells = volume::GridCells(model.opening.polygon, cell);
        if (cells > config.heightmap.max_cells) {
            return absl::InvalidArgumentError(absl::StrCat(
                "grid_cell_m: ", cell, " m gives ", static_cast<long long>(cells),
                " cells over the opening; at most ", config.heightmap.max_cells, " are allowed"));
        }
        // The paper's per-cell planes need points in (nearly) every cell; below that its hole
        // filling extrapolates far planes into nonsense. The registration scan's density tells.
        const double density =
            static_cast<double>(model.inside.size()) / std::max(container.opening_area_m2(), 1e-9);
        const double per_cell = density * cell * cell;
        if (config.method == volume::Method::kPaper && per_cell < kPaperMinPointsPerCell) {
            return absl::FailedPreconditionError(
                absl::StrCat("grid_cell_m: ", cell, " m cells would hold about ", per_cell,
                             " points each (registration scan density); the paper method needs ",
                             kPaperMinPointsPerCell, ": use cells of at least ",
                             std::sqrt(kPaperMinPointsPerCell / std::max(density, 1e-9)),
                             " m or the heightmap method"));
        }
        config.heightmap.cell_m = cell;
        config.paper.cell_m = cell;
    }
    if (request.has_material_density_kg_m3()) {
        const double density = request.material_density_kg_m3();
        if (!std::isfinite(density) || density <= 0.0 || density > kMaxDensityKgM3) {
            return absl::InvalidArgumentError(absl::StrCat(
                "material_density_kg_m3: must be in (0, ", kMaxDensityKgM3, "] kg/m^3"));
        }
    }
    if (container.has_max_range_m()) config.preprocess.max_range_m = container.max_range_m();
    return config;
}

/// The model lives in the frame of the sensor it was registered from: a scan must come from
/// the same kind of sensor and, for stereo, the same calibration.
absl::Status CheckSameSensor(const v1::Scan& scan, const v1::Container& container) {
    const bool stereo_model = container.registered_from() == v1::SCAN_KIND_STEREO;
    if (scan.has_cloud() && stereo_model) {
        return absl::FailedPreconditionError(
            absl::StrCat("scan.cloud: container '", container.container_id(),
                         "' was registered from stereo pairs (calibration '",
                         container.calibration_id(), "'); send a stereo scan"));
    }
    if (scan.has_stereo() && !stereo_model) {
        return absl::FailedPreconditionError(
            absl::StrCat("scan.stereo: container '", container.container_id(),
                         "' was registered from a point cloud; send a cloud scan"));
    }
    if (scan.has_stereo() && !scan.stereo().calibration_id().empty() &&
        scan.stereo().calibration_id() != container.calibration_id()) {
        return absl::FailedPreconditionError(absl::StrCat(
            "scan.stereo.calibration_id: container '", container.container_id(),
            "' was registered with calibration '", container.calibration_id(), "', not '",
            scan.stereo().calibration_id(), "'; register it again to use another rig"));
    }
    return absl::OkStatus();
}

}  // namespace

absl::Status SoilVolumeHandlers::EstimateVolume(const v1::EstimateVolumeRequest& request,
                                                v1::EstimateVolumeResponse* response,
                                                CallRecord& record) {
    Timer timer;
    record.ids.push_back({"container", request.container_id()});
    if (!request.request_id().empty()) record.ids.push_back({"request", request.request_id()});
    SOILVOL_ASSIGN_OR_RETURN(auto container, LoadContainer(request.container_id(), "container_id"));
    SOILVOL_ASSIGN_OR_RETURN(const pipeline::EstimateConfig config,
                             EstimateConfigFor(request, container->info, container->model));
    SOILVOL_RETURN_IF_ERROR(CheckSameSensor(request.scan(), container->info));
    SOILVOL_ASSIGN_OR_RETURN(const Scan scan,
                             DecodeScan(request.scan(), container->info.calibration_id(), record));

    v1::Timings* timings = response->mutable_timings();
    absl::StatusOr<pipeline::VolumeEstimate> estimate;
    if (scan.calibration != nullptr) {
        pipeline::StereoEstimateConfig stereo_config;
        stereo_config.estimate = config;
        absl::StatusOr<pipeline::StereoEstimate> stereo =
            pipeline::EstimateVolumeStereo(container->model, *scan.calibration->stereo,
                                           {scan.left, scan.right}, stereo_config, record.stop);
        if (!stereo.ok()) return stereo.status();
        timings->set_decode_ms(stereo->stereo.decode_ms);
        timings->set_rectify_ms(stereo->stereo.rectify_ms);
        timings->set_match_ms(stereo->stereo.match_ms);
        timings->set_reproject_ms(stereo->stereo.reproject_ms);
        estimate = std::move(stereo->estimate);
    } else {
        timings->set_decode_ms(scan.decode_ms);
        estimate = pipeline::EstimateVolume(container->model, scan.cloud, config, record.stop);
    }
    if (!estimate.ok()) return estimate.status();

    ToProto(*estimate, response);
    response->set_container_id(request.container_id());
    response->set_request_id(request.request_id());
    response->set_method(config.method == volume::Method::kPaper ? v1::ESTIMATION_METHOD_PAPER
                                                                 : v1::ESTIMATION_METHOD_HEIGHTMAP);
    if (request.has_material_density_kg_m3()) {
        response->set_mass_kg(estimate->volume_m3 * request.material_density_kg_m3());
    }
    timings->set_queue_ms(record.queue_ms);
    timings->set_total_ms(record.queue_ms + timer.Lap());
    for (const auto& [stage, ms] : {std::pair<const char*, double>{"decode", timings->decode_ms()},
                                    {"rectify", timings->rectify_ms()},
                                    {"match", timings->match_ms()},
                                    {"reproject", timings->reproject_ms()},
                                    {"preprocess", timings->preprocess_ms()},
                                    {"align", timings->align_ms()},
                                    {"volume", timings->volume_ms()}}) {
        if (ms > 0.0) record.stages_ms.push_back({stage, ms});
    }
    record.volume_m3 = estimate->volume_m3;
    return absl::OkStatus();
}

}  // namespace soilvol::server
