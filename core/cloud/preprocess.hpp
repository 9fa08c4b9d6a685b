#pragma once

#include <cstddef>

#include "core/cloud/outlier_filter.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"

namespace soilvol::cloud {

/// Paper Sec. 3.1: background removal by range, then statistical outlier removal; optional
/// voxel downsampling last.
struct PreprocessConfig {
    double max_range_m = 0.0;  ///< points farther than this from the sensor are background; 0 = off
    double min_range_m =
        0.0;  ///< points nearer than this are dropped (sensor housing, dust); 0 = off
    bool remove_outliers = true;
    OutlierFilterConfig outliers;
    double voxel_size_m = 0.0;  ///< centroid per voxel; 0 = off
};

struct PreprocessResult {
    Cloud points;
    std::size_t input_points = 0;
    std::size_t after_range = 0;
    std::size_t after_outliers = 0;
    double range_ms = 0.0;
    double outliers_ms = 0.0;
    double voxel_ms = 0.0;
};

/// Runs the configured steps in order on a scan-frame cloud (sensor at the origin). On a `stop`
/// it returns early with a partial result; the caller checks the token.
PreprocessResult Preprocess(const Cloud& points, const PreprocessConfig& config,
                            const StopToken& stop = {});

}  // namespace soilvol::cloud
