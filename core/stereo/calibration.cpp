#include "core/stereo/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <new>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/stereo/chessboard_detector.hpp"
#include "core/stereo/image_header.hpp"
#include "core/stereo/opencv_camera.hpp"
#include "core/stereo/rectification.hpp"

namespace soilvol::stereo {
namespace {

constexpr std::size_t kFewestPairs = 3;  // below this a planar calibration is not determined
constexpr int kMaxBoardCorners = 100;    // inner corners along one side

struct StereoFit {
    StereoParameters parameters;
    double rms_px = 0.0;
    std::vector<std::size_t> views;  // the fitted views, positions in BoardViews
    cv::Mat per_view_errors;         // a row per fitted view: RMS [px] in the left, right image
};

absl::Status ValidateInputs(const ChessboardSpec& board, const CalibrationConfig& config) {
    for (const auto& [name, corners] :
         {std::pair{"board.cols", board.cols}, std::pair{"board.rows", board.rows}}) {
        if (corners < 2 || corners > kMaxBoardCorners) {
            return absl::InvalidArgumentError(
                absl::StrCat(name, " must be in [2, ", kMaxBoardCorners, "], got ", corners));
        }
    }
    if (!std::isfinite(board.square_size_m) || board.square_size_m <= 0.0) {
        return absl::InvalidArgumentError("board.square_size_m must be positive and finite");
    }
    if (!std::isfinite(config.max_rms_px) || config.max_rms_px <= 0.0) {
        return absl::InvalidArgumentError("config.max_rms_px must be positive and finite");
    }
    if (config.max_image_side_px < detail::kMinImageSidePx ||
        config.max_image_side_px > detail::kMaxImageSidePx) {
        return absl::InvalidArgumentError(
            absl::StrCat("config.max_image_side_px must be in [", detail::kMinImageSidePx, ", ",
                         detail::kMaxImageSidePx, "], got ", config.max_image_side_px));
    }
    return absl::OkStatus();
}

std::string SkipSummary(const std::vector<SkippedPair>& skipped) {
    std::map<std::string, int> counts;
    for (const SkippedPair& pair : skipped) ++counts[pair.reason];
    std::string summary;
    for (const auto& [reason, count] : counts) {
        absl::StrAppend(&summary, summary.empty() ? "" : "; ", count, " x ", reason);
    }
    return summary.empty() ? "none" : summary;
}

std::vector<cv::Point3f> BoardPoints(const ChessboardSpec& board) {
    std::vector<cv::Point3f> points;
    const auto square = static_cast<float>(board.square_size_m);
    for (int r = 0; r < board.rows; ++r) {
        for (int c = 0; c < board.cols; ++c) {
            points.emplace_back(static_cast<float>(c) * square, static_cast<float>(r) * square,
                                0.0f);
        }
    }
    return points;
}

// The views the fits take: all of them up to max_fit, else max_fit spread evenly.
std::vector<std::size_t> FitViews(std::size_t usable, std::size_t max_fit) {
    const std::size_t count = std::min(usable, std::max(max_fit, kFewestPairs));
    std::vector<std::size_t> views(count);
    for (std::size_t k = 0; k < count; ++k) views[k] = k * usable / count;
    return views;
}

// Zhang's method for each camera alone, then cv::stereoCalibrate refining both cameras and the
// pair jointly from those intrinsics (lower RMS than fixing them, same baseline within 0.01%).
// No OpenCV fit can be interrupted: the stop is checked between them.
absl::StatusOr<StereoFit> FitStereo(const detail::BoardViews& views, const ChessboardSpec& board,
                                    const CalibrationConfig& config, const StopToken& stop) {
    StereoFit fit;
    fit.views = FitViews(views.left.size(), config.max_fit_pairs);
    std::vector<std::vector<cv::Point2f>> left, right;
    for (const std::size_t v : fit.views) {
        left.push_back(views.left[v]);
        right.push_back(views.right[v]);
    }
    const std::vector<std::vector<cv::Point3f>> objects(left.size(), BoardPoints(board));
    const int distortion_flags = config.fix_k3 ? cv::CALIB_FIX_K3 : 0;
    cv::Mat k_left, d_left, k_right, d_right, rotation, translation, essential, fundamental;
    std::vector<cv::Mat> rvecs, tvecs;
    SOILVOL_RETURN_IF_ERROR(stop.Check("calibration of the left camera"));
    cv::calibrateCamera(objects, left, views.image_size, k_left, d_left, rvecs, tvecs,
                        distortion_flags);
    SOILVOL_RETURN_IF_ERROR(stop.Check("calibration of the right camera"));
    cv::calibrateCamera(objects, right, views.image_size, k_right, d_right, rvecs, tvecs,
                        distortion_flags);
    SOILVOL_RETURN_IF_ERROR(stop.Check("stereo calibration"));
    fit.rms_px = cv::stereoCalibrate(
        objects, left, right, k_left, d_left, k_right, d_right, views.image_size, rotation,
        translation, essential, fundamental, fit.per_view_errors,
        cv::CALIB_USE_INTRINSIC_GUESS | distortion_flags,
        cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
    fit.parameters.image_width = views.image_size.width;
    fit.parameters.image_height = views.image_size.height;
    fit.parameters.left = detail::ToIntrinsics(k_left, d_left);
    fit.parameters.right = detail::ToIntrinsics(k_right, d_right);
    cv::cv2eigen(rotation, fit.parameters.R_right_left);
    cv::cv2eigen(translation, fit.parameters.t_right_left_m);
    return fit;
}

// Stereo RMS [px] of a pair left out of the fits: the board's pose from its left image
// (solvePnP), projected into both images.
double HeldOutRms(const std::vector<cv::Point3f>& board, const std::vector<cv::Point2f>& left,
                  const std::vector<cv::Point2f>& right, const StereoParameters& parameters) {
    const cv::Mat k_left = detail::CameraMatrix(parameters.left);
    const cv::Mat d_left = detail::DistortionRow(parameters.left);
    cv::Mat rvec, tvec, rotation, rvec_pair, translation, rvec_right, tvec_right;
    cv::solvePnP(board, left, k_left, d_left, rvec, tvec);
    cv::eigen2cv(parameters.R_right_left, rotation);
    cv::eigen2cv(parameters.t_right_left_m, translation);
    cv::Rodrigues(rotation, rvec_pair);
    cv::composeRT(rvec, tvec, rvec_pair, translation, rvec_right, tvec_right);
    std::vector<cv::Point2f> in_left, in_right;
    cv::projectPoints(board, rvec, tvec, k_left, d_left, in_left);
    cv::projectPoints(board, rvec_right, tvec_right, detail::CameraMatrix(parameters.right),
                      detail::DistortionRow(parameters.right), in_right);
    double sum = 0.0;
    for (std::size_t i = 0; i < board.size(); ++i) {
        const cv::Point2f l = in_left[i] - left[i];
        const cv::Point2f r = in_right[i] - right[i];
        sum += static_cast<double>(l.dot(l) + r.dot(r));
    }
    return std::sqrt(sum / (2.0 * static_cast<double>(board.size())));
}

// Mean |y_left - y_right| [px] of one view's corners after undistortion and rectification.
double EpipolarError(const std::vector<cv::Point2f>& left, const std::vector<cv::Point2f>& right,
                     const StereoCalibration& calibration) {
    cv::Mat r1, r2, p1, p2;
    cv::eigen2cv(calibration.R1, r1);
    cv::eigen2cv(calibration.R2, r2);
    cv::eigen2cv(calibration.P1, p1);
    cv::eigen2cv(calibration.P2, p2);
    std::vector<cv::Point2f> rectified_left, rectified_right;
    const StereoParameters& parameters = calibration.parameters;
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-6);
    cv::undistortPoints(left, rectified_left, detail::CameraMatrix(parameters.left),
                        detail::DistortionRow(parameters.left), r1, p1, criteria);
    cv::undistortPoints(right, rectified_right, detail::CameraMatrix(parameters.right),
                        detail::DistortionRow(parameters.right), r2, p2, criteria);
    double sum = 0.0;
    for (std::size_t i = 0; i < left.size(); ++i) {
        sum += std::abs(static_cast<double>(rectified_left[i].y - rectified_right[i].y));
    }
    return sum / static_cast<double>(left.size());
}

void FillPairFigures(const detail::BoardViews& views, const StereoFit& fit,
                     const ChessboardSpec& board, StereoCalibration* calibration) {
    std::vector<int> row(views.indices.size(), -1);
    for (std::size_t r = 0; r < fit.views.size(); ++r) row[fit.views[r]] = static_cast<int>(r);
    double epipolar_sum = 0.0;
    for (std::size_t i = 0; i < views.indices.size(); ++i) {
        PairError pair{views.indices[i], 0.0,
                       EpipolarError(views.left[i], views.right[i], *calibration), row[i] >= 0};
        if (pair.fitted) {
            const double left = fit.per_view_errors.at<double>(row[i], 0);
            const double right = fit.per_view_errors.at<double>(row[i], 1);
            pair.rms_px = std::sqrt(0.5 * (left * left + right * right));
        } else {
            pair.rms_px = HeldOutRms(BoardPoints(board), views.left[i], views.right[i],
                                     calibration->parameters);
        }
        epipolar_sum += pair.epipolar_px;
        calibration->pairs.push_back(pair);
    }
    calibration->mean_epipolar_px = epipolar_sum / static_cast<double>(views.indices.size());
}

// The pairs' count and pixels from their headers, before any image is decoded.
absl::Status CheckWork(const std::vector<ImagePair>& pairs, const CalibrationConfig& config) {
    if (pairs.size() > config.max_pairs) {
        return absl::InvalidArgumentError(
            absl::StrCat("pairs: at most ", config.max_pairs, " pairs, got ", pairs.size()));
    }
    std::int64_t total = 0;
    const std::int64_t side = config.max_image_side_px;
    for (const ImagePair& pair : pairs) {
        for (const std::string_view image : {pair.left, pair.right}) {
            // Sides past the limit are refused image by image; count them at the limit.
            if (const auto size = detail::PeekImageSize(image)) {
                total += std::clamp<std::int64_t>(size->width, 0, side) *
                         std::clamp<std::int64_t>(size->height, 0, side);
            }
        }
    }
    if (total > config.max_total_pixels) {
        return absl::InvalidArgumentError(
            absl::StrCat("pairs: ", total, " pixels in all; at most ", config.max_total_pixels,
                         " per call (fewer pairs, or smaller images)"));
    }
    return absl::OkStatus();
}

absl::StatusOr<StereoCalibration> Calibrate(const std::vector<ImagePair>& pairs,
                                            const ChessboardSpec& board,
                                            const CalibrationConfig& config,
                                            const StopToken& stop) {
    SOILVOL_RETURN_IF_ERROR(CheckWork(pairs, config));
    SOILVOL_ASSIGN_OR_RETURN(detail::BoardViews views,
                             detail::DetectBoards(pairs, board, config.max_image_side_px, stop));
    const std::size_t needed = std::max(config.min_pairs, kFewestPairs);
    if (views.indices.size() < needed) {
        return absl::FailedPreconditionError(
            absl::StrCat(views.indices.size(), " usable chessboard pairs of ", pairs.size(), ", ",
                         needed, " needed; skipped: ", SkipSummary(views.skipped)));
    }
    SOILVOL_ASSIGN_OR_RETURN(const StereoFit fit, FitStereo(views, board, config, stop));
    if (!(fit.rms_px <= config.max_rms_px)) {
        return absl::FailedPreconditionError(absl::StrCat(
            "stereo reprojection RMS ", fit.rms_px, " px exceeds max_rms_px ", config.max_rms_px));
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check("rectification"));
    absl::StatusOr<StereoCalibration> calibration = detail::Rectify(fit.parameters);
    if (!calibration.ok()) {
        return absl::FailedPreconditionError(absl::StrCat(
            "the chessboards gave unusable parameters: ", calibration.status().message()));
    }
    calibration->rms_reprojection_px = fit.rms_px;
    SOILVOL_RETURN_IF_ERROR(stop.Check("per-pair figures"));
    FillPairFigures(views, fit, board, &*calibration);
    if (!(calibration->baseline_m >= config.min_baseline_m)) {
        return absl::FailedPreconditionError(absl::StrCat(
            "the chessboards gave a degenerate rig: baseline ", calibration->baseline_m,
            " m (at least ", config.min_baseline_m, " m), reprojection RMS ", fit.rms_px,
            " px; the boards must be seen by both cameras from several angles"));
    }
    if (!(calibration->mean_epipolar_px <= config.max_epipolar_px)) {
        return absl::FailedPreconditionError(
            absl::StrCat("the chessboards gave a degenerate rig: rectified corners differ by ",
                         calibration->mean_epipolar_px, " px in row on average (at most ",
                         config.max_epipolar_px, " px), baseline ", calibration->baseline_m,
                         " m; check that left and right images are paired and from a fixed rig"));
    }
    calibration->skipped = std::move(views.skipped);
    calibration->source = "chessboard";
    return calibration;
}

}  // namespace

absl::StatusOr<StereoCalibration> CalibrateFromChessboards(const std::vector<ImagePair>& pairs,
                                                           const ChessboardSpec& board,
                                                           const CalibrationConfig& config,
                                                           const StopToken& stop) {
    SOILVOL_RETURN_IF_ERROR(ValidateInputs(board, config));
    try {
        return Calibrate(pairs, board, config, stop);
    } catch (const cv::Exception& e) {
        return absl::InternalError(absl::StrCat("chessboard calibration failed: ", e.what()));
    } catch (const std::bad_alloc&) {
        return absl::ResourceExhaustedError("chessboard calibration: out of memory");
    } catch (const std::exception& e) {
        return absl::InternalError(absl::StrCat("chessboard calibration failed: ", e.what()));
    }
}

absl::StatusOr<StereoCalibration> CalibrationFromParameters(const StereoParameters& parameters) {
    SOILVOL_ASSIGN_OR_RETURN(StereoCalibration calibration, detail::Rectify(parameters));
    calibration.source = "parameters";
    return calibration;
}

}  // namespace soilvol::stereo
