#include "core/pipeline/stereo_estimator.hpp"

#include <algorithm>
#include <cmath>

#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"

namespace soilvol::pipeline {
namespace {

// The model's bounding rectangle in the rectified image at the expected pose, with margin.
stereo::PixelRect ModelRegion(const model::ContainerModel& model,
                              const stereo::StereoReconstructor& stereo,
                              const Pose& T_scan_container, const StereoEstimateConfig& config) {
    Cloud points = model.alignment_points;
    points.insert(points.end(), model.inside.begin(), model.inside.end());
    const stereo::PixelRect tight = stereo.RegionOf(points, T_scan_container, 0);
    if (tight.Empty()) return {};
    const int side = std::max(tight.u1 - tight.u0, tight.v1 - tight.v0);
    const int margin = std::max(config.region_margin_px,
                                static_cast<int>(std::ceil(config.region_margin_share * side)));
    const StereoParameters& p = stereo.calibration().parameters;
    return tight.Grown(margin, p.image_width, p.image_height);
}

}  // namespace

absl::StatusOr<StereoModel> BuildStereoContainerModel(const stereo::StereoReconstructor& stereo,
                                                      const StereoPair& pair,
                                                      const OpeningMarks& opening,
                                                      const model::ModelConfig& config,
                                                      const stereo::PixelCornerConfig& lift,
                                                      const StopToken& stop) {
    StereoModel result;
    SOILVOL_ASSIGN_OR_RETURN(stereo::StereoCloud cloud,
                             stereo.Reconstruct(pair.left, pair.right, {}, stop));
    result.timings = cloud.timings;
    result.stereo_points = cloud.points.size();
    Corners corners;
    if (const auto* pixels = std::get_if<stereo::PixelCorners>(&opening)) {
        SOILVOL_ASSIGN_OR_RETURN(result.lifted,
                                 stereo::LiftPixelCorners(stereo, cloud.disparity, *pixels, lift));
        corners = result.lifted->corners;
    } else {
        corners = std::get<Corners>(opening);
    }
    SOILVOL_ASSIGN_OR_RETURN(result.model,
                             model::BuildContainerModel(cloud.points, corners, config, stop));
    return result;
}

absl::StatusOr<StereoEstimate> EstimateVolumeStereo(const model::ContainerModel& model,
                                                    const stereo::StereoReconstructor& stereo,
                                                    const StereoPair& pair,
                                                    const StereoEstimateConfig& config,
                                                    const StopToken& stop) {
    Timer total;
    StereoEstimate result;
    if (config.match_model_region) {
        const Pose expected =
            config.estimate.initial_T_scan_container.value_or(model.opening.T_scan_container);
        result.region = ModelRegion(model, stereo, expected, config);
    }
    SOILVOL_ASSIGN_OR_RETURN(stereo::StereoCloud cloud,
                             stereo.Reconstruct(pair.left, pair.right, result.region, stop));
    result.stereo = cloud.timings;
    result.stereo_points = cloud.points.size();
    SOILVOL_ASSIGN_OR_RETURN(result.estimate,
                             EstimateVolume(model, cloud.points, config.estimate, stop));
    result.total_ms = total.Lap();
    return result;
}

}  // namespace soilvol::pipeline
