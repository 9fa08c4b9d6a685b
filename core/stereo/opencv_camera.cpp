#include "core/stereo/opencv_camera.hpp"

namespace soilvol::stereo::detail {

cv::Mat CameraMatrix(const CameraIntrinsics& intrinsics) {
    return (cv::Mat_<double>(3, 3) << intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy,
            intrinsics.cy, 0.0, 0.0, 1.0);
}

cv::Mat DistortionRow(const CameraIntrinsics& intrinsics) {
    if (intrinsics.distortion.empty()) return cv::Mat();
    return cv::Mat(intrinsics.distortion, true).reshape(1, 1);
}

CameraIntrinsics ToIntrinsics(const cv::Mat& camera_matrix, const cv::Mat& distortion) {
    CameraIntrinsics intrinsics;
    intrinsics.fx = camera_matrix.at<double>(0, 0);
    intrinsics.fy = camera_matrix.at<double>(1, 1);
    intrinsics.cx = camera_matrix.at<double>(0, 2);
    intrinsics.cy = camera_matrix.at<double>(1, 2);
    if (distortion.empty()) return intrinsics;
    const cv::Mat row =
        distortion.isContinuous() ? distortion.reshape(1, 1) : distortion.clone().reshape(1, 1);
    intrinsics.distortion.assign(row.ptr<double>(), row.ptr<double>() + row.total());
    return intrinsics;
}

}  // namespace soilvol::stereo::detail
