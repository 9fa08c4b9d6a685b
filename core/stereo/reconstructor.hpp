#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <memory>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"
#include "core/stereo/calibration.hpp"
#include "core/stereo/disparity.hpp"

namespace soilvol::stereo {

struct ReconstructConfig {
    SgbmConfig sgbm;
    double min_range_m = 0.3;  ///< nearer points are dropped
    double max_range_m = 8.0;  ///< farther points (and disparities <= 0) are dropped
    /// Valid pixels are taken on a regular stride chosen so that at most this many points come
    /// out (0: every pixel). Stereo gives one point per pixel, far more than a 3-5 cm grid needs.
    std::size_t max_points = 60000;
    /// Block matching carries the nearer side of a depth edge some pixels across it (foreground
    /// fattening) and smooths the step into a ramp. Pixels within edge_band_px (< 0: half the
    /// block) of a jump larger than edge_jump_px between neighbours, or of a pixel without a
    /// disparity, are left out of the cloud. 0 keeps them.
    double edge_jump_px = 1.0;
    int edge_band_px = -1;
    int max_image_side_px = 8192;
};

/// Wall-clock time per stage [ms].
struct StereoTimings {
    double decode_ms = 0.0;
    double rectify_ms = 0.0;
    double match_ms = 0.0;
    double reproject_ms = 0.0;
};

/// A reconstructed scan: points in the rectified left camera frame [m] (x right, y down,
/// z forward), the disparity map they came from and the timings.
struct StereoCloud {
    Cloud points;
    DisparityMap disparity;  ///< rectified left image
    int stride = 1;          ///< pixel stride the points were taken on
    StereoTimings timings;
};

/// Turns stereo pairs into clouds for one calibration (paper Sec. 3.1): decode, rectify with
/// maps computed once, SGBM, reproject through Q, mask invalid disparities and cut by range.
/// Immutable after Create; Reconstruct may run concurrently from several threads.
class StereoReconstructor {
  public:
    /// InvalidArgument for bad SGBM parameters, ranges or an unrectified calibration.
    static absl::StatusOr<StereoReconstructor> Create(const StereoCalibration& calibration,
                                                      const ReconstructConfig& config = {});

    /// Encoded images (8/16-bit, grey or colour) of the calibration's size; InvalidArgument
    /// naming "left"/"right" otherwise. Only `region` (rectified left pixels; empty = all) is
    /// matched. DeadlineExceeded or Cancelled, naming the stage, once `stop` asks for it.
    absl::StatusOr<StereoCloud> Reconstruct(std::string_view left, std::string_view right,
                                            PixelRect region = {},
                                            const StopToken& stop = {}) const;
    absl::StatusOr<StereoCloud> Reconstruct(const GreyImage& left, const GreyImage& right,
                                            PixelRect region = {},
                                            const StopToken& stop = {}) const;

    /// Rectified left pixel of a pixel on the left image as uploaded (distorted).
    Eigen::Vector2d RectifyLeftPixel(const Eigen::Vector2d& raw_px) const;
    /// Rectified left pixel of a point in the rectified left frame (NaN behind the camera).
    Eigen::Vector2d ProjectRectified(const Eigen::Vector3d& point) const;
    /// The point [m] at rectified left pixel (u, v) with disparity d [px] (Q reprojection).
    Eigen::Vector3d Reproject(double u, double v, double d) const;
    /// Bounding rectangle of `points` (rectified left frame) in the rectified image, grown by
    /// margin_px and clipped to it; empty when no point is in front of the camera.
    PixelRect RegionOf(const Cloud& points, const Pose& T_rectified_points, int margin_px) const;

    const StereoCalibration& calibration() const;
    const ReconstructConfig& config() const;

  private:
    struct Impl;
    explicit StereoReconstructor(std::shared_ptr<const Impl> impl);
    std::shared_ptr<const Impl> impl_;
};

}  // namespace soilvol::stereo
