#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/camera.hpp"
#include "core/common/stop_token.hpp"

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
    /// OpenCV's fits solve one dense system over every pair's board pose, at a cost that grows
    /// with the cube of the pairs and that nothing can interrupt (200 VGA pairs: 70-80 s for
    /// each camera, 18 s for the pair, seconds an iteration). With more usable pairs than this,
    /// that many spread evenly over them are fitted and the others judged against the result
    /// (PairError::fitted): 20 pairs take 0.1-0.3 s a fit, and on 200 rendered pairs the
    /// baseline from 20 of them was 0.05% off the truth (from all 200: 0.005%).
    std::size_t max_fit_pairs = 20;
};

/// Per-pair figures of a chessboard calibration.
struct PairError {
    int index = 0;             ///< position in the input
    double rms_px = 0.0;       ///< stereo reprojection RMS over both images
    double epipolar_px = 0.0;  ///< mean |y_left - y_right| of the rectified corners
    /// False for a pair left out of the fits (CalibrationConfig::max_fit_pairs): its RMS is that
    /// of the board pose its left image gives, projected into both images.
    bool fitted = true;
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
/// than min_pairs remain or the fit is worse than max_rms_px; DeadlineExceeded or Cancelled,
/// naming the stage (and pair), once `stop` asks for it.
absl::StatusOr<StereoCalibration> CalibrateFromChessboards(const std::vector<ImagePair>& pairs,
                                                           const ChessboardSpec& board,
                                                           const CalibrationConfig& config = {},
                                                           const StopToken& stop = {});

/// Board searches still running after their call stopped: OpenCV's search cannot be cut short,
/// so a stopped call returns and leaves it to finish alone (at most 2 at a time, each ~20 s at
/// worst). A process exiting while one runs should end without unloading OpenCV (std::_Exit).
int AbandonedBoardSearches();

/// Rectifies known parameters (factory calibration). InvalidArgument naming the field for a
/// non-positive or non-finite focal length, a principal point outside the image, a bad
/// distortion count (0, 4, 5, 8), a rotation that is not proper, a zero baseline or an image
/// size out of range.
absl::StatusOr<StereoCalibration> CalibrationFromParameters(const StereoParameters& parameters);

}  // namespace soilvol::stereo
