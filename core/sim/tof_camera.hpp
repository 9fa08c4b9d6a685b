#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "core/common/camera.hpp"
#include "core/common/image.hpp"
#include "core/common/types.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/scene_raycaster.hpp"

namespace soilvol::sim {

/// A time-of-flight camera (the ifm O3D/O3R, Basler blaze, SICK Visionary-T class): a pinhole
/// pixel grid whose depth carries what such cameras do to it.
struct TofCameraSpec {
    int width = 320;
    int height = 240;
    double horizontal_fov_deg = 60.0;
    /// Range noise (1 sigma) at 1 m, head-on, on a surface of full amplitude; it grows with
    /// range and falls with the square root of the amplitude (shot noise): sigma =
    /// noise_at_1m_m * r / sqrt(cos(incidence)).
    double noise_at_1m_m = 0.002;
    /// Pixels whose relative amplitude (cos(incidence) / r^2, 1 head-on at 1 m) is below this
    /// return nothing.
    double min_amplitude = 0.002;
    /// A pixel returns the light of its whole footprint (footprint_samples^2 sub-rays), the
    /// amplitude-weighted mean of their ranges: where the footprint straddles a depth edge, a
    /// mix of both surfaces ("flying pixel"). Off: each pixel returns its centre ray's hit.
    bool flying_pixels = true;
    int footprint_samples = 4;
    /// Light bounced off a facing surface pushes returns long near concave corners: up to
    /// multipath_m in the corner, falling off as exp(-distance / multipath_reach_m) from it.
    double multipath_m = 0.0;
    double multipath_reach_m = 0.15;
};

/// A typical camera of that class (Basler blaze-101, ifm O3R, SICK Visionary-T): 640x480
/// over 67 deg, 3 mm noise at 1 m head-on, flying pixels at every depth edge, multipath up to
/// 2 cm in concave corners.
TofCameraSpec TypicalTofCamera();

/// One frame: the z-depth image [m] (float; 0 where nothing returned), the amplitude image
/// (relative, as the spec defines it), the camera, and the simulator's truth per pixel.
struct TofFrame {
    ScalarImage depth;
    ScalarImage amplitude;
    CameraIntrinsics intrinsics;
    std::vector<float> true_range_m;  ///< the centre ray's range before any artefact; 0: miss
    /// Amplitude share of the footprint's light from other surfaces than the centre ray's
    /// (ranges more than 3% apart); 0: pure.
    std::vector<float> mix_share;
    std::vector<float> other_range_m;  ///< their amplitude-weighted range; 0: pure
    std::vector<float> multipath_m;    ///< the bias added
};

/// The frame of `scene` (container frame) placed at `T_scan_container` in the camera frame
/// (x right, y down, z forward). Noise is drawn from `rng`.
TofFrame RenderTof(const SceneRaycaster& scene, const Pose& T_scan_container,
                   const TofCameraSpec& spec, std::mt19937_64* rng);

/// `spec`'s scan taken by a ToF camera instead of its sensor's ray grid: the container and soil
/// placed as SimulateScene places them (spec.sensor gives the viewpoint), with the truth, and
/// the frame (scene.points is left empty: the depth image is the scan).
struct TofScene {
    Scene scene;
    TofFrame frame;
};
TofScene SimulateTofScene(const SceneSpec& spec, const TofCameraSpec& camera);

}  // namespace soilvol::sim
