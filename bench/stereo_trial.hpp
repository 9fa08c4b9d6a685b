#pragma once

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "core/pipeline/stereo_estimator.hpp"
#include "core/sim/stereo_renderer.hpp"
#include "core/stereo/calibration.hpp"
#include "core/stereo/reconstructor.hpp"

namespace soilvol::bench {

/// A rendered stereo set-up: container, rig, viewpoint, motion between scans, calibration.
struct StereoSetup {
    sim::ContainerKind container = sim::ContainerKind::kPaperBucket;
    sim::StereoRigSpec rig;
    sim::SensorSpec view;  ///< distance, elevation, azimuth only
    sim::PoseJitter jitter{3.0, 0.05};
    bool calibrate_from_chessboards = true;  ///< else the rig's exact parameters
    int chessboard_views = 15;
    double corner_click_sigma_px = 1.0;  ///< error of the marked pixel corners
};

/// The paper's rig (Sec. 3.1: 10 cm baseline, 2-3 m away) at `width` x `height` for `kind`.
StereoSetup PaperRig(sim::ContainerKind kind, int width = 640, int height = 480);

/// The calibration the set-up uses: rendered chessboards through CalibrateFromChessboards, or
/// the exact parameters. `ms` gets the calibration time.
absl::StatusOr<stereo::StereoCalibration> CalibrateRig(const StereoSetup& setup, uint64_t seed,
                                                       double* ms = nullptr);

/// A rendered pair as PNG bytes with its truth.
struct RenderedPair {
    std::string left_png;
    std::string right_png;
    sim::StereoScene scene;
};
RenderedPair RenderPair(const StereoSetup& setup, double fill_m, uint64_t soil_seed,
                        uint64_t scan_seed);

/// The empty container registered from a rendered pair with (noisy) pixel corners.
struct StereoRegistered {
    absl::StatusOr<pipeline::StereoModel> model;
    double true_struck_m3 = 0.0;
    double register_ms = 0.0;
};
StereoRegistered RegisterStereoEmpty(const StereoSetup& setup,
                                     const stereo::StereoReconstructor& stereo, uint64_t seed);

}  // namespace soilvol::bench
