#include "bench/stereo_trial.hpp"

#include <random>
#include <vector>

#include "core/common/timer.hpp"
#include "core/sim/tof_sensor.hpp"
#include "core/stereo/image_codec.hpp"

namespace soilvol::bench {
namespace {

std::string Png(const GreyImage& image) {
    absl::StatusOr<std::string> png = stereo::EncodePng(image);
    return png.ok() ? *std::move(png) : std::string();
}

}  // namespace

StereoSetup PaperRig(sim::ContainerKind kind, int width, int height) {
    StereoSetup setup;
    setup.container = kind;
    setup.rig.image_width = width;
    setup.rig.image_height = height;
    setup.view = sim::ViewpointFor(kind);
    setup.view.distance_m = sim::FramingDistance(kind, setup.view, setup.rig);
    return setup;
}

absl::StatusOr<stereo::StereoCalibration> CalibrateRig(const StereoSetup& setup, uint64_t seed,
                                                       double* ms) {
    Timer timer;
    absl::StatusOr<stereo::StereoCalibration> calibration;
    if (!setup.calibrate_from_chessboards) {
        calibration = stereo::CalibrationFromParameters(sim::RigParameters(setup.rig));
    } else {
        const stereo::ChessboardSpec board{9, 6, 0.06};
        std::vector<stereo::ImagePair> pairs;
        for (const sim::ChessboardView& view :
             sim::RenderChessboards(setup.rig, board.cols, board.rows, board.square_size_m,
                                    setup.chessboard_views, seed)) {
            pairs.push_back({Png(view.left), Png(view.right)});
        }
        timer.Lap();
        calibration = stereo::CalibrateFromChessboards(pairs, board);
    }
    if (ms != nullptr) *ms = timer.Lap();
    return calibration;
}

RenderedPair RenderPair(const StereoSetup& setup, double fill_m, uint64_t soil_seed,
                        uint64_t scan_seed) {
    sim::SceneSpec spec;
    spec.container = setup.container;
    spec.sensor = setup.view;
    spec.jitter = setup.jitter;
    spec.soil.fill_height_m = fill_m;
    spec.soil_seed = soil_seed;
    spec.scan_seed = scan_seed;
    RenderedPair pair;
    pair.scene = sim::RenderStereoScene(spec, setup.rig);
    pair.left_png = Png(pair.scene.left);
    pair.right_png = Png(pair.scene.right);
    return pair;
}

StereoRegistered RegisterStereoEmpty(const StereoSetup& setup,
                                     const stereo::StereoReconstructor& stereo, uint64_t seed) {
    const RenderedPair pair = RenderPair(setup, 0.0, seed, seed * 1000);
    stereo::PixelCorners corners = pair.scene.opening_corners_px;
    std::mt19937_64 rng(seed * 7919);
    std::normal_distribution<double> click(0.0, setup.corner_click_sigma_px);
    for (Eigen::Vector2d& c : corners) c += Eigen::Vector2d(click(rng), click(rng));
    StereoRegistered out{absl::UnknownError("not run"), pair.scene.struck_capacity_m3, 0.0};
    Timer timer;
    out.model = pipeline::BuildStereoContainerModel(stereo, {pair.left_png, pair.right_png},
                                                    corners, model::ModelConfig{});
    out.register_ms = timer.Lap();
    return out;
}

}  // namespace soilvol::bench
