#include "core/stereo/rectification.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <new>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <string>

#include "absl/strings/str_cat.h"
#include "core/stereo/opencv_camera.hpp"

namespace soilvol::stereo::detail {
namespace {

constexpr double kRotationTolerance = 1e-6;  // max |R^T R - I|
constexpr double kMaxBaselineM = 100.0;      // past any rig on a machine or a site mast
constexpr double kMaxFocalPx = 1e6;          // a 1 mrad field of view on 1000 px

absl::Status Invalid(absl::string_view field, absl::string_view problem) {
    return absl::InvalidArgumentError(absl::StrCat(field, " ", problem));
}

absl::Status CheckSide(absl::string_view field, int side) {
    if (side < kMinImageSidePx || side > kMaxImageSidePx) {
        return Invalid(field, absl::StrCat("must be in [", kMinImageSidePx, ", ", kMaxImageSidePx,
                                           "], got ", side));
    }
    return absl::OkStatus();
}

absl::Status CheckCamera(absl::string_view name, const CameraIntrinsics& camera, int width,
                         int height) {
    const auto field = [&](absl::string_view key) { return absl::StrCat(name, ".", key); };
    if (!std::isfinite(camera.fx) || camera.fx <= 0.0) {
        return Invalid(field("fx"), "must be positive and finite");
    }
    if (!std::isfinite(camera.fy) || camera.fy <= 0.0) {
        return Invalid(field("fy"), "must be positive and finite");
    }
    if (camera.fx > kMaxFocalPx || camera.fy > kMaxFocalPx) {
        return Invalid(field(camera.fx > kMaxFocalPx ? "fx" : "fy"),
                       absl::StrCat("must be at most ", kMaxFocalPx, " px"));
    }
    if (!std::isfinite(camera.cx) || camera.cx < 0.0 || camera.cx > width) {
        return Invalid(field("cx"), absl::StrCat("must be inside the image [0, ", width, "]"));
    }
    if (!std::isfinite(camera.cy) || camera.cy < 0.0 || camera.cy > height) {
        return Invalid(field("cy"), absl::StrCat("must be inside the image [0, ", height, "]"));
    }
    const std::size_t count = camera.distortion.size();
    if (count != 0 && count != 4 && count != 5 && count != 8) {
        return Invalid(field("distortion"),
                       absl::StrCat("must have 0, 4, 5 or 8 coefficients, got ", count));
    }
    for (std::size_t i = 0; i < count; ++i) {
        if (!std::isfinite(camera.distortion[i])) {
            return Invalid(field(absl::StrCat("distortion[", i, "]")), "must be finite");
        }
    }
    return absl::OkStatus();
}

bool AllFinite(const cv::Mat& matrix) { return cv::checkRange(matrix, true, nullptr); }

}  // namespace

absl::Status ValidateStereoParameters(const StereoParameters& parameters) {
    if (absl::Status s = CheckSide("image_width", parameters.image_width); !s.ok()) return s;
    if (absl::Status s = CheckSide("image_height", parameters.image_height); !s.ok()) return s;
    for (const auto& [name, camera] :
         {std::pair{"left", &parameters.left}, std::pair{"right", &parameters.right}}) {
        if (absl::Status s =
                CheckCamera(name, *camera, parameters.image_width, parameters.image_height);
            !s.ok()) {
            return s;
        }
    }
    const Eigen::Matrix3d& rotation = parameters.R_right_left;
    if (!rotation.allFinite()) return Invalid("R_right_left", "must be finite");
    const double orthogonality =
        (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    const double determinant = rotation.determinant();
    if (orthogonality > kRotationTolerance || determinant <= 0.0) {
        return Invalid("R_right_left", absl::StrCat("is not a proper rotation (det=", determinant,
                                                    ", max|R^T R - I|=", orthogonality, ")"));
    }
    const Eigen::Vector3d& translation = parameters.t_right_left_m;
    if (!translation.allFinite()) return Invalid("t_right_left_m", "must be finite");
    if (translation.norm() <= 0.0) return Invalid("t_right_left_m", "is zero");
    if (!(translation.norm() <= kMaxBaselineM)) {  // NaN too: the norm of huge values overflows
        return Invalid("t_right_left_m",
                       absl::StrCat("gives a baseline past ", kMaxBaselineM, " m"));
    }
    return absl::OkStatus();
}

absl::StatusOr<StereoCalibration> Rectify(const StereoParameters& parameters) {
    if (absl::Status s = ValidateStereoParameters(parameters); !s.ok()) return s;
    StereoCalibration calibration;
    calibration.parameters = parameters;
    try {
        cv::Mat rotation;
        cv::Mat translation;
        cv::eigen2cv(parameters.R_right_left, rotation);
        cv::eigen2cv(parameters.t_right_left_m, translation);
        cv::Mat r1, r2, p1, p2, q;
        const cv::Size size(parameters.image_width, parameters.image_height);
        cv::stereoRectify(CameraMatrix(parameters.left), DistortionRow(parameters.left),
                          CameraMatrix(parameters.right), DistortionRow(parameters.right), size,
                          rotation, translation, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY,
                          /*alpha=*/-1.0, size);
        if (!AllFinite(r1) || !AllFinite(r2) || !AllFinite(p1) || !AllFinite(p2) || !AllFinite(q)) {
            return absl::InvalidArgumentError("parameters give a non-finite rectification");
        }
        cv::cv2eigen(r1, calibration.R1);
        cv::cv2eigen(r2, calibration.R2);
        cv::cv2eigen(p1, calibration.P1);
        cv::cv2eigen(p2, calibration.P2);
        cv::cv2eigen(q, calibration.Q);
    } catch (const cv::Exception& e) {
        return absl::InvalidArgumentError(absl::StrCat("rectification failed: ", e.what()));
    } catch (const std::bad_alloc&) {
        return absl::ResourceExhaustedError("rectification: out of memory");
    } catch (const std::exception& e) {
        return absl::InternalError(absl::StrCat("rectification failed: ", e.what()));
    }
    calibration.baseline_m = parameters.t_right_left_m.norm();
    calibration.focal_px = calibration.P1(0, 0);
    if (!(calibration.focal_px > 0.0 && std::isfinite(calibration.focal_px))) {
        return absl::InvalidArgumentError(
            absl::StrCat("parameters give a degenerate rectification (focal length ",
                         calibration.focal_px, " px)"));
    }
    return calibration;
}

}  // namespace soilvol::stereo::detail
