#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>

#include "absl/status/statusor.h"
#include "core/common/types.hpp"
#include "core/stereo/disparity.hpp"
#include "core/stereo/reconstructor.hpp"

namespace soilvol::stereo {

/// Four opening corners marked on the left image as uploaded [px], ordered around the opening.
using PixelCorners = std::array<Eigen::Vector2d, 4>;

/// Lifting marked corners to 3D. The rim is flat, and a plane in space is an affine function
/// d = a u + b v + c of disparity over rectified pixels, so one plane is fitted (RANSAC, then
/// least squares on the inliers) to the disparities in a band along the four marked edges, and
/// each corner takes the plane's disparity at its rectified pixel.
struct PixelCornerConfig {
    double band_px = 5.0;    ///< half width of the band along each edge
    double inlier_px = 0.5;  ///< disparity residual of a plane inlier
    int ransac_iterations = 400;
    std::size_t min_inliers = 40;
    double min_edge_px = 8.0;  ///< shorter edges are refused
    uint64_t seed = 1;
};

struct LiftedCorners {
    Corners corners;  ///< rectified left camera frame [m]
    std::array<Eigen::Vector2d, 4> rectified_px;
    Eigen::Vector3d plane = Eigen::Vector3d::Zero();  ///< (a, b, c): d = a u + b v + c
    std::size_t band_pixels = 0;                      ///< valid disparities in the band
    std::size_t inliers = 0;
    double rms_px = 0.0;  ///< disparity RMS of the inliers
};

/// InvalidArgument naming the corner for non-finite or out-of-image pixels, a degenerate or
/// self-intersecting quadrilateral; FailedPrecondition when the rim has too few valid
/// disparities or no plane fits (the message gives the counts).
absl::StatusOr<LiftedCorners> LiftPixelCorners(const StereoReconstructor& reconstructor,
                                               const DisparityMap& disparity,
                                               const PixelCorners& corners_px,
                                               const PixelCornerConfig& config = {});

}  // namespace soilvol::stereo
