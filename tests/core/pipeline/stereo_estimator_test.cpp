#include "core/pipeline/stereo_estimator.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "core/sim/stereo_renderer.hpp"
#include "core/stereo/image_codec.hpp"
#include "tests/core/common/counting_stop.hpp"

namespace soilvol::pipeline {
namespace {

using sim::ContainerKind;

std::string Png(const GreyImage& image) {
    auto png = stereo::EncodePng(image);
    EXPECT_TRUE(png.ok()) << png.status();
    return png.ok() ? *png : std::string();
}

// The paper's rig (640x480, 10 cm baseline); 3 m keeps the whole 2.05 m bucket in view.
sim::SceneSpec View(double fill_m, uint64_t scan_seed) {
    sim::SceneSpec spec;
    spec.container = ContainerKind::kPaperBucket;
    spec.sensor = sim::ViewpointFor(spec.container);
    spec.sensor.distance_m = 3.0;
    spec.jitter = {3.0, 0.05};
    spec.soil.fill_height_m = fill_m;
    spec.soil_seed = 5;
    spec.scan_seed = scan_seed;
    return spec;
}

struct Pair {
    std::string left, right;
    sim::StereoScene scene;
};

Pair Render(double fill_m, uint64_t scan_seed) {
    Pair pair;
    pair.scene = sim::RenderStereoScene(View(fill_m, scan_seed), sim::StereoRigSpec{});
    pair.left = Png(pair.scene.left);
    pair.right = Png(pair.scene.right);
    return pair;
}

// A calibration and the reconstructor built on it.
struct Rig {
    stereo::StereoCalibration calibration;
    std::unique_ptr<stereo::StereoReconstructor> stereo;
};

Rig MakeRig(const absl::StatusOr<stereo::StereoCalibration>& calibration) {
    Rig rig;
    EXPECT_TRUE(calibration.ok()) << calibration.status();
    if (!calibration.ok()) return rig;
    rig.calibration = *calibration;
    auto reconstructor = stereo::StereoReconstructor::Create(*calibration);
    EXPECT_TRUE(reconstructor.ok()) << reconstructor.status();
    if (reconstructor.ok()) {
        rig.stereo = std::make_unique<stereo::StereoReconstructor>(*std::move(reconstructor));
    }
    return rig;
}

// The suite works with the rig's exact calibration; the tests whose subject is the chessboard
// calibration (it renders 12 board pairs and calibrates from them: most of a test's time, and
// ctest runs each test in its own process) ask for it with ChessboardRig().
class StereoEstimatorTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        exact_ = new Rig(
            MakeRig(stereo::CalibrationFromParameters(sim::RigParameters(sim::StereoRigSpec{}))));
        calibration_ = &exact_->calibration;
        stereo_ = exact_->stereo.get();
        empty_ = new Pair(Render(0.0, 100));
    }
    static void TearDownTestSuite() {
        delete exact_;
        delete empty_;
    }
    void SetUp() override { ASSERT_NE(stereo_, nullptr) << "no reconstructor for the exact rig"; }

    // Calibrated from rendered chessboard pairs, once per process.
    static const Rig& ChessboardRig() {
        static const Rig* const rig = [] {
            const sim::StereoRigSpec spec;
            std::vector<stereo::ImagePair> boards;
            for (const auto& view : sim::RenderChessboards(spec, 9, 6, 0.06, 12, 3)) {
                boards.push_back({Png(view.left), Png(view.right)});
            }
            return new Rig(MakeRig(stereo::CalibrateFromChessboards(boards, {9, 6, 0.06})));
        }();
        return *rig;
    }

    // Corners as a person clicks them: the true pixels with 1 px error.
    static stereo::PixelCorners Clicked(uint64_t seed) {
        stereo::PixelCorners corners = empty_->scene.opening_corners_px;
        std::mt19937_64 rng(seed);
        std::normal_distribution<double> click(0.0, 1.0);
        for (Eigen::Vector2d& c : corners) c += Eigen::Vector2d(click(rng), click(rng));
        return corners;
    }

    static Rig* exact_;
    static const stereo::StereoCalibration* calibration_;
    static const stereo::StereoReconstructor* stereo_;
    static Pair* empty_;
};

Rig* StereoEstimatorTest::exact_ = nullptr;
const stereo::StereoCalibration* StereoEstimatorTest::calibration_ = nullptr;
const stereo::StereoReconstructor* StereoEstimatorTest::stereo_ = nullptr;
Pair* StereoEstimatorTest::empty_ = nullptr;

// Volume scales with the cube of the baseline, so the calibration must get it right first.
TEST_F(StereoEstimatorTest, RenderedChessboardsGiveTheBaselineWithinOnePercent) {
    const stereo::StereoCalibration& calibration = ChessboardRig().calibration;
    ASSERT_EQ(calibration.source, "chessboard");
    EXPECT_NEAR(calibration.baseline_m, 0.10, 0.001);
    EXPECT_LT(calibration.rms_reprojection_px, 0.3);
    EXPECT_NEAR(calibration.parameters.left.fx, sim::RigParameters({}).left.fx, 0.01 * 554.0);
}

// Pixel corners lifted through the rim plane land on the true corners (rectified frame) within
// a few pixels' footprint at 3 m (5 mm/px) and the depth resolution there.
TEST_F(StereoEstimatorTest, PixelCornersLiftToTheTrueCorners) {
    const auto cloud = stereo_->Reconstruct(empty_->left, empty_->right);
    ASSERT_TRUE(cloud.ok()) << cloud.status();
    const auto lifted = stereo::LiftPixelCorners(*stereo_, cloud->disparity, Clicked(1));
    ASSERT_TRUE(lifted.ok()) << lifted.status();
    for (int i = 0; i < 4; ++i) {
        const Eigen::Vector3d truth = calibration_->R1 * empty_->scene.opening_corners_left[i];
        EXPECT_LT((lifted->corners[i] - truth).norm(), 0.04) << "corner " << i;
    }
    EXPECT_GT(lifted->inliers, lifted->band_pixels / 2);
}

// The end-to-end check: register from a pair with pixel corners, estimate fills from new
// pairs with the container moved. Target 3% of struck (BENCHMARK.md reports the figures per
// fill); the test allows 6% so that it flags regressions, not seed-to-seed scatter: the
// registered capacity reads 6% low from stereo, and the full bucket with it (issue 11, item 6).
TEST_F(StereoEstimatorTest, FillsAreMeasuredFromRenderedPairs) {
    const Rig& chessboard = ChessboardRig();
    ASSERT_NE(chessboard.stereo, nullptr);
    const stereo::StereoReconstructor& stereo = *chessboard.stereo;
    const auto model = BuildStereoContainerModel(stereo, {empty_->left, empty_->right}, Clicked(2),
                                                 model::ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    const double struck = empty_->scene.struck_capacity_m3;
    EXPECT_NEAR(model->model.struck_capacity_m3, struck, 0.08 * struck);
    uint64_t seed = 101;
    for (const double fill : {0.0, 0.2, 0.4, 0.6}) {
        const Pair pair = Render(fill, seed++);
        const auto e = EstimateVolumeStereo(model->model, stereo, {pair.left, pair.right}, {});
        ASSERT_TRUE(e.ok()) << e.status();
        EXPECT_NEAR(e->estimate.volume_m3, pair.scene.true_volume_m3, 0.06 * struck)
            << "fill " << fill;
        EXPECT_FALSE(e->region.Empty());
    }
}

// A stop anywhere in a stereo registration or estimate ends it with the stop's status; a token
// that never stops changes nothing.
TEST_F(StereoEstimatorTest, StopsEndStereoCallsWithTheirStatus) {
    const StereoPair empty{empty_->left, empty_->right};
    const auto model = BuildStereoContainerModel(*stereo_, empty, Clicked(2), model::ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    const Pair pair = Render(0.3, 200);
    const StereoPair full{pair.left, pair.right};
    const auto plain = EstimateVolumeStereo(model->model, *stereo_, full, {});
    const test::CountingStop never(0);
    const auto watched = EstimateVolumeStereo(model->model, *stereo_, full, {}, never.token());
    ASSERT_TRUE(plain.ok() && watched.ok());
    EXPECT_NEAR(watched->estimate.volume_m3, plain->estimate.volume_m3, 1e-9);

    const StopToken expired(StopToken::Clock::now() - std::chrono::seconds(1));
    EXPECT_EQ(EstimateVolumeStereo(model->model, *stereo_, full, {}, expired).status().message(),
              "deadline expired during image decoding");
    EXPECT_EQ(
        BuildStereoContainerModel(*stereo_, empty, Clicked(2), {}, {}, expired).status().code(),
        absl::StatusCode::kDeadlineExceeded);
    const long last = never.looks() - 2;  // ICP may take an iteration less another time
    for (const long look : {1L, last / 2, last}) {
        const test::CountingStop cancel(look);
        const auto e = EstimateVolumeStereo(model->model, *stereo_, full, {}, cancel.token());
        EXPECT_EQ(e.status().code(), absl::StatusCode::kCancelled) << look << ": " << e.status();
    }
    const test::CountingStop never_model(0);
    ASSERT_TRUE(
        BuildStereoContainerModel(*stereo_, empty, Clicked(2), {}, {}, never_model.token()).ok());
    const long last_model = never_model.looks();
    for (const long look : {1L, last_model / 2, last_model}) {
        const test::CountingStop cancel(look);
        const auto m =
            BuildStereoContainerModel(*stereo_, empty, Clicked(2), {}, {}, cancel.token());
        EXPECT_EQ(m.status().code(), absl::StatusCode::kCancelled) << look << ": " << m.status();
    }
}

TEST_F(StereoEstimatorTest, BadCornersAreInvalidArgument) {
    const auto cloud = stereo_->Reconstruct(empty_->left, empty_->right);
    ASSERT_TRUE(cloud.ok());
    stereo::PixelCorners outside = Clicked(3);
    outside[2] = {700.0, 10.0};
    stereo::PixelCorners nan = Clicked(3);
    nan[1].x() = std::numeric_limits<double>::quiet_NaN();
    stereo::PixelCorners crossed = Clicked(3);
    std::swap(crossed[1], crossed[2]);
    stereo::PixelCorners collapsed = Clicked(3);
    collapsed[1] = collapsed[0];
    for (const auto& corners : {outside, nan, crossed, collapsed}) {
        const auto lifted = stereo::LiftPixelCorners(*stereo_, cloud->disparity, corners);
        EXPECT_EQ(lifted.status().code(), absl::StatusCode::kInvalidArgument) << lifted.status();
    }
}

// Corners marked on the sky at infinity have no disparities to fit a rim plane to.
TEST_F(StereoEstimatorTest, CornersOffTheContainerAreFailedPrecondition) {
    const auto cloud = stereo_->Reconstruct(empty_->left, empty_->right);
    ASSERT_TRUE(cloud.ok());
    const stereo::PixelCorners sky = {Eigen::Vector2d(590, 20), Eigen::Vector2d(630, 20),
                                      Eigen::Vector2d(630, 60), Eigen::Vector2d(590, 60)};
    EXPECT_EQ(stereo::LiftPixelCorners(*stereo_, cloud->disparity, sky).status().code(),
              absl::StatusCode::kFailedPrecondition);
}

TEST_F(StereoEstimatorTest, BadImagesAreInvalidArgumentNamingTheSide) {
    GreyImage small{320, 240, std::vector<uint8_t>(320 * 240, 90)};
    const std::string small_png = Png(small);
    const auto swapped =
        EstimateVolumeStereo(model::ContainerModel{}, *stereo_, {empty_->left, small_png}, {});
    EXPECT_EQ(swapped.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(swapped.status().message().find("right"), std::string::npos) << swapped.status();
    const auto garbage =
        BuildStereoContainerModel(*stereo_, {"not an image", empty_->right}, Clicked(4), {});
    EXPECT_EQ(garbage.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(garbage.status().message().find("left"), std::string::npos) << garbage.status();
}

}  // namespace
}  // namespace soilvol::pipeline
