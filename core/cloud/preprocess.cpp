#include "core/cloud/preprocess.hpp"

#include "core/cloud/voxel_grid.hpp"
#include "core/common/timer.hpp"

namespace soilvol::cloud {
namespace {

Cloud CropRange(const Cloud& points, double min_range_m, double max_range_m) {
    if (min_range_m <= 0.0 && max_range_m <= 0.0) return points;
    const double lo2 = min_range_m * min_range_m;
    const double hi2 = max_range_m > 0.0 ? max_range_m * max_range_m : 1e300;
    Cloud out;
    out.reserve(points.size());
    for (const auto& p : points) {
        const double r2 = static_cast<double>(p.squaredNorm());
        if (r2 >= lo2 && r2 <= hi2) out.push_back(p);
    }
    return out;
}

}  // namespace

PreprocessResult Preprocess(const Cloud& points, const PreprocessConfig& config,
                            const StopToken& stop) {
    PreprocessResult result;
    Timer timer;
    result.input_points = points.size();
    // Sec. 3.1: background subtraction by maximum expected distance.
    result.points = CropRange(points, config.min_range_m, config.max_range_m);
    result.after_range = result.points.size();
    result.range_ms = timer.Lap();
    // Sec. 3.1: statistical outlier removal.
    if (stop.StopRequested()) return result;
    if (config.remove_outliers) {
        result.points = RemoveStatisticalOutliers(result.points, config.outliers, stop).kept;
    }
    result.after_outliers = result.points.size();
    result.outliers_ms = timer.Lap();
    if (config.voxel_size_m > 0.0 && !stop.StopRequested())
        result.points = VoxelDownsample(result.points, config.voxel_size_m);
    result.voxel_ms = timer.Lap();
    return result;
}

}  // namespace soilvol::cloud
