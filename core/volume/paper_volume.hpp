#pragma once

#include "absl/status/statusor.h"
#include "core/common/polygon.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/volume/volume_result.hpp"

namespace soilvol::volume {

/// Paper Sec. 3.4, as published: the baseline soilvol's estimator is measured against.
struct PaperConfig {
    double cell_m = 0.10;              ///< Table 1 uses 10 cm
    double ransac_threshold_m = 0.02;  ///< per-cell plane RANSAC inlier distance (not in the paper)
    int ransac_iterations = 100;
    int min_points = 3;  ///< fewer points make a cell a hole
};

/// Per cell of a ceil(L/c) x ceil(W/c) grid over the opening's bounding box (whole cells, as the
/// paper's cell counts show): a RANSAC plane in the model and in the scan, holes take the mean
/// plane coefficients of the nearest cells that have one, height = Euclidean distance between
/// the median points of the two planes, volume = sum of height x cell area.
/// FailedPrecondition when the model or the scan has no cell with a plane; DeadlineExceeded or
/// Cancelled once `stop` asks for it.
absl::StatusOr<VolumeResult> PaperVolume(const Cloud& empty_inside, const Cloud& scan_column,
                                         const Polygon2d& opening, const PaperConfig& config,
                                         const StopToken& stop = {});

}  // namespace soilvol::volume
