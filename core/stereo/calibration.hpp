#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/camera.hpp"

namespace soilvol::stereo {

/// A chessboard pattern: inner corners along a row (cols) and a column (rows), square side [m].
struct ChessboardSpec {
    int cols = 9;
    int rows = 6;
    double square_size_m = 0.025;
};

/// One stereo pair of encoded images (PNG, JPEG, ... as bytes).
struct ImagePair {
    std::string left;
    std::string right;
};

struct CalibrationConfig {
    std::size_t min_pairs = 5;  ///< fewer usable pairs (or < 3) is FailedPrecondition
    bool fix_k3 = true;         ///< estimate k1, k2, p1, p2 only (webcam-class lenses)
    double max_rms_px = 2.0;    ///< a worse stereo fit is FailedPrecondition
    /// Degenerate fits are refused with their figures, never stored: rectified corners of one
    /// pair must agree in row within this mean [px] ...
    double max_epipolar_px = 1.0;
    double min_baseline_m = 0.001;  ///< ... and the cameras must stand at least this far apart
    int max_image_side_px = 8192;   ///< larger images are InvalidArgument; at most 8192
    /// Work a call may ask for, checked from the image headers before any is decoded: more
    /// pairs, or more pixels over all of them (200 pairs of 1.2 MP), are InvalidArgument.
    std::size_t max_pairs = 200;
    std::int64_t max_total_pixels = 500'000'000;
};

/// Per-pair figures of a chessboard calibration.
struct PairError {
    int index = 0;             ///< position in the input
    double rms_px = 0.0;       ///< stereo reprojection RMS over both images
    double epipolar_px = 0.0;  ///< mean |y_left - y_right| of the rectified corners
};

/// A pair the calibration could not use, with the reason ("left: chessboard not found", ...).
struct SkippedPair {
    int index = 0;
    std::string reason;
};

/// A calibrated, rectified stereo pair. Rectification follows cv::stereoRectify with
/// CALIB_ZERO_DISPARITY: rectified left camera frame = left camera frame rotated by R1;
/// disparity d at rectified left pixel (u, v) gives X = Q * (u, v, d, 1) (homogeneous).
struct StereoCalibration {
    StereoParameters parameters;
    Eigen::Matrix3d R1 = Eigen::Matrix3d::Identity();  ///< left camera -> rectified left
    Eigen::Matrix3d R2 = Eigen::Matrix3d::Identity();  ///< right camera -> rectified right
    Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero();
    Eigen::Matrix<double, 3, 4> P2 = Eigen::Matrix<double, 3, 4>::Zero();
    Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
    double baseline_m = 0.0;  ///< |t_right_left_m|
    double focal_px = 0.0;    ///< rectified focal length P1(0, 0)
    /// Chessboard calibrations only (0 / empty otherwise).
    double rms_reprojection_px = 0.0;
    double mean_epipolar_px = 0.0;
    std::vector<PairError> pairs;
    std::vector<SkippedPair> skipped;
    std::string source;  ///< "chessboard" or "parameters"
};

/// Calibrates from chessboard pairs: corners with sub-pixel refinement in both images, each
/// camera alone, then the pair (cv::stereoCalibrate), then rectification. Pairs without a
/// board in both images, undecodable images or sizes that differ from the first usable pair
/// are skipped with the reason. InvalidArgument for a bad spec; FailedPrecondition when fewer
/// than min_pairs remain or the fit is worse than max_rms_px.
absl::StatusOr<StereoCalibration> CalibrateFromChessboards(const std::vector<ImagePair>& pairs,
                                                           const ChessboardSpec& board,
                                                           const CalibrationConfig& config = {});

/// Rectifies known parameters (factory calibration). InvalidArgument naming the field for a
/// non-positive or non-finite focal length, a principal point outside the image, a bad
/// distortion count (0, 4, 5, 8), a rotation that is not proper, a zero baseline or an image
/// size out of range.
absl::StatusOr<StereoCalibration> CalibrationFromParameters(const StereoParameters& parameters);

}  // namespace soilvol::stereo
