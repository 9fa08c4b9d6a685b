#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "core/common/camera.hpp"
#include "core/common/image.hpp"
#include "core/common/types.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::sim {

/// A stereo camera pair: two equal pinhole cameras with OpenCV-model distortion, the right one
/// baseline_m to the right of the left one and turned by a small rotation (so that
/// rectification has work to do). The left camera frame is the scan frame of SceneSpec's sensor
/// (x right, y down, z forward).
struct StereoRigSpec {
    int image_width = 640;
    int image_height = 480;
    double horizontal_fov_deg = 60.0;
    double baseline_m = 0.10;
    std::vector<double> distortion = {-0.08, 0.02, 0.0, 0.0, 0.0};         ///< both cameras
    Eigen::Vector3d right_rotation_deg = Eigen::Vector3d(0.3, -0.5, 0.2);  ///< rotation vector
    double pixel_noise_sigma = 2.0;  ///< Gaussian grey-level noise per pixel
    int supersampling = 2;           ///< rays per pixel side (anti-aliasing)
};

/// The exact parameters of `rig` in OpenCV's convention.
StereoParameters RigParameters(const StereoRigSpec& rig);

/// Left-image pixel (distorted, as uploaded) of a point in the left camera frame, and the same
/// for the right camera; nullopt-free: points behind a camera project to NaN.
Eigen::Vector2d ProjectLeft(const StereoRigSpec& rig, const Eigen::Vector3d& X_left);
Eigen::Vector2d ProjectRight(const StereoRigSpec& rig, const Eigen::Vector3d& X_left);

/// The nearest distance [m] from 2.5 m (in 0.25 m steps, below 8 m) at which `view` sees the
/// whole opening of `kind` at least `margin_px` inside the left image (the paper: 2-3 m).
double FramingDistance(ContainerKind kind, SensorSpec view, const StereoRigSpec& rig,
                       double margin_px = 40.0);

/// A rendered stereo view of a simulated scene with its exact ground truth.
struct StereoScene {
    GreyImage left;
    GreyImage right;
    StereoParameters parameters;   ///< exact
    Pose T_left_container;         ///< true container pose in the left camera frame
    Corners opening_corners_left;  ///< true opening corners in the left camera frame [m]
    std::array<Eigen::Vector2d, 4> opening_corners_px;  ///< the same, as left-image pixels
    double true_volume_m3 = 0.0;
    double struck_capacity_m3 = 0.0;
    double heaped_capacity_sae_m3 = 0.0;
};

/// Renders `spec` (container, soil, viewpoint from spec.sensor's distance, elevation and
/// azimuth, jitter; range noise and resolution are ignored) with textured Lambertian surfaces:
/// soil and container carry different world-anchored textures, the background is a texture at
/// infinity. Deterministic for a given spec and rig.
StereoScene RenderStereoScene(const SceneSpec& spec, const StereoRigSpec& rig);

/// One rendered chessboard pose with the true inner-corner pixels (row by row, as
/// cv::findChessboardCorners orders them for an upright board).
struct ChessboardView {
    GreyImage left;
    GreyImage right;
    std::vector<Eigen::Vector2d> corners_left_px;
    std::vector<Eigen::Vector2d> corners_right_px;
    Pose T_left_board;
};

/// `count` views of a cols x rows (inner corners) chessboard with squares of square_size_m and
/// a white border, at seeded random poses fully visible in both cameras. A board that cannot be
/// placed 0.6-1.6 m away gives fewer views; invalid sizes or counts give none.
std::vector<ChessboardView> RenderChessboards(const StereoRigSpec& rig, int cols, int rows,
                                              double square_size_m, int count, uint64_t seed);

}  // namespace soilvol::sim
