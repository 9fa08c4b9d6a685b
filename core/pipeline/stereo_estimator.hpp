#pragma once

#include <cstddef>
#include <optional>
#include <string_view>
#include <variant>

#include "absl/status/statusor.h"
#include "core/model/container_model.hpp"
#include "core/pipeline/estimator.hpp"
#include "core/stereo/pixel_corners.hpp"
#include "core/stereo/reconstructor.hpp"

namespace soilvol::pipeline {

/// Two encoded images of one stereo pair (PNG, JPEG, ... bytes), left and right as calibrated.
struct StereoPair {
    std::string_view left;
    std::string_view right;
};

/// Opening corners: in 3D in the rectified left camera frame, or marked as pixels on the left
/// image as uploaded (lifted through the rim's disparities).
using OpeningMarks = std::variant<Corners, stereo::PixelCorners>;

struct StereoModel {
    model::ContainerModel model;                  ///< scan frame = rectified left camera frame
    std::optional<stereo::LiftedCorners> lifted;  ///< set when the corners were pixels
    stereo::StereoTimings timings;
    std::size_t stereo_points = 0;
};

/// Reconstructs the empty container from `pair` and builds its model (paper Sec. 3.2).
/// Errors as StereoReconstructor::Reconstruct, LiftPixelCorners and BuildContainerModel;
/// DeadlineExceeded or Cancelled, naming the stage, once `stop` asks for it.
absl::StatusOr<StereoModel> BuildStereoContainerModel(const stereo::StereoReconstructor& stereo,
                                                      const StereoPair& pair,
                                                      const OpeningMarks& opening,
                                                      const model::ModelConfig& config,
                                                      const stereo::PixelCornerConfig& lift = {},
                                                      const StopToken& stop = {});

/// Stereo errors are correlated over whole patches (a block matcher's window spans several
/// cells), so a cell's own sigma says less about them: the contents check is looser.
inline EstimateConfig StereoDefaults() {
    EstimateConfig config;
    config.max_below_empty_share = 0.5;
    return config;
}

struct StereoEstimateConfig {
    EstimateConfig estimate = StereoDefaults();
    /// Match only where the container can be: the model's bounding rectangle at the initial
    /// pose, grown by max(region_margin_px, region_margin_share x its larger side).
    bool match_model_region = true;
    int region_margin_px = 32;
    double region_margin_share = 0.15;
};

struct StereoEstimate {
    VolumeEstimate estimate;
    stereo::StereoTimings stereo;
    stereo::PixelRect region;  ///< matched region (empty: the whole image)
    std::size_t stereo_points = 0;
    double total_ms = 0.0;  ///< from the encoded images to the volume
};

/// Stereo pair -> cloud -> EstimateVolume (Sec. 3.1-3.4). Errors as Reconstruct and
/// EstimateVolume, a stop's among them.
absl::StatusOr<StereoEstimate> EstimateVolumeStereo(const model::ContainerModel& model,
                                                    const stereo::StereoReconstructor& stereo,
                                                    const StereoPair& pair,
                                                    const StereoEstimateConfig& config,
                                                    const StopToken& stop = {});

}  // namespace soilvol::pipeline
