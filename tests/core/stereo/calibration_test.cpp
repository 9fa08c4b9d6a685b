#include "core/stereo/calibration.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tests/core/common/counting_stop.hpp"
#include "tests/core/stereo/stereo_test_util.hpp"

namespace soilvol::stereo {
namespace {

using soilvol::test::CountingStop;
using test::HasError;
using test::IsInvalidWith;

// OpenCV 4.6's samples/cpp/stereo_calib.cpp on the same 13 pairs (square size 1) prints
// "RMS error=0.634183", "average epipolar err = 0.445411" and T = (-3.3427, 0.0468, 0.0037).
constexpr double kSampleBaselineSquares = 3.3430;
constexpr double kBaselineTolerance = 0.03 * kSampleBaselineSquares;
constexpr double kMaxRmsPx = 0.5;
const ChessboardSpec kBoard{9, 6, 1.0};
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string ReencodePng(const std::string& jpeg, int rotate_code) {
    cv::Mat image = cv::imdecode(
        cv::Mat(1, static_cast<int>(jpeg.size()), CV_8UC1, const_cast<char*>(jpeg.data())),
        cv::IMREAD_UNCHANGED);
    if (rotate_code >= 0) cv::rotate(image, image, rotate_code);
    std::vector<uchar> png;
    cv::imencode(".png", image, png);
    return std::string(png.begin(), png.end());
}

// The 13-pair calibration runs at most once per process, and only for the tests that read it
// (they start with ASSERT_TRUE(Calibrated())): ctest runs each test in its own process.
class SamplePairsTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() { pairs_ = test::SamplePairs(); }
    void SetUp() override { SOILVOL_NEED_SAMPLES(pairs_.empty(), "opencv-doc sample pairs"); }
    static ::testing::AssertionResult Calibrated() {
        if (!result_) result_ = CalibrateFromChessboards(pairs_, kBoard);
        if (result_->ok()) return ::testing::AssertionSuccess();
        return ::testing::AssertionFailure() << result_->status();
    }
    const StereoCalibration& Calibration() const { return **result_; }

    static inline std::vector<ImagePair> pairs_;
    static inline std::optional<absl::StatusOr<StereoCalibration>> result_;
};

TEST_F(SamplePairsTest, AllPairsCalibrateWithinOpenCvSampleFigures) {
    ASSERT_TRUE(Calibrated());
    const StereoCalibration& calibration = Calibration();
    EXPECT_EQ(calibration.source, "chessboard");
    EXPECT_TRUE(calibration.skipped.empty());
    ASSERT_EQ(calibration.pairs.size(), 13u);
    EXPECT_LE(calibration.rms_reprojection_px, kMaxRmsPx);
    EXPECT_NEAR(calibration.baseline_m, kSampleBaselineSquares, kBaselineTolerance);
    EXPECT_LT(calibration.mean_epipolar_px, 0.445411);  // the sample's figure
    EXPECT_EQ(calibration.parameters.image_width, 640);
    EXPECT_EQ(calibration.parameters.image_height, 480);
    EXPECT_EQ(calibration.parameters.left.distortion.size(), 5u);
    EXPECT_EQ(calibration.parameters.left.distortion[4], 0.0);  // fix_k3
}

TEST_F(SamplePairsTest, PerPairFiguresAddUpToTheOverallOnes) {
    ASSERT_TRUE(Calibrated());
    const StereoCalibration& calibration = Calibration();
    double squared = 0.0;
    double epipolar = 0.0;
    for (std::size_t i = 0; i < calibration.pairs.size(); ++i) {
        const PairError& pair = calibration.pairs[i];
        EXPECT_EQ(pair.index, static_cast<int>(i));
        EXPECT_GT(pair.rms_px, 0.0);
        EXPECT_LT(pair.rms_px, kMaxRmsPx);
        EXPECT_LT(pair.epipolar_px, kMaxRmsPx);
        squared += pair.rms_px * pair.rms_px;
        epipolar += pair.epipolar_px;
    }
    const double count = static_cast<double>(calibration.pairs.size());
    EXPECT_NEAR(std::sqrt(squared / count), calibration.rms_reprojection_px, 1e-9);
    EXPECT_NEAR(epipolar / count, calibration.mean_epipolar_px, 1e-12);
}

TEST_F(SamplePairsTest, RectificationIsHorizontalWithOpenCvSigns) {
    ASSERT_TRUE(Calibrated());
    const StereoCalibration& calibration = Calibration();
    const double focal = calibration.focal_px;
    EXPECT_EQ(focal, calibration.P1(0, 0));
    EXPECT_EQ(focal, calibration.Q(2, 3));
    EXPECT_NEAR(calibration.P2(0, 3), -focal * calibration.baseline_m, 1e-6 * focal);
    EXPECT_NEAR(calibration.Q(3, 2), 1.0 / calibration.baseline_m, 1e-9);
    EXPECT_EQ(calibration.P2(1, 3), 0.0);
    EXPECT_EQ(calibration.P1(0, 2), calibration.P2(0, 2));      // CALIB_ZERO_DISPARITY
    EXPECT_LT(calibration.parameters.t_right_left_m.x(), 0.0);  // right camera on the right
}

TEST_F(SamplePairsTest, BaselineScalesWithSquareSize) {
    ASSERT_TRUE(Calibrated());
    const auto scaled = CalibrateFromChessboards(pairs_, {9, 6, 0.025});
    ASSERT_TRUE(scaled.ok()) << scaled.status();
    EXPECT_NEAR(scaled->baseline_m, 0.025 * Calibration().baseline_m, 1e-6);
    EXPECT_NEAR(scaled->rms_reprojection_px, Calibration().rms_reprojection_px, 1e-6);
}

TEST_F(SamplePairsTest, TooFewPairsIsFailedPrecondition) {
    const std::vector<ImagePair> three(pairs_.begin(), pairs_.begin() + 3);
    const auto result = CalibrateFromChessboards(three, kBoard);
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kFailedPrecondition,
                         "3 usable chessboard pairs of 3, 5 needed"));
}

// Issue 12 item 8: a rig that is no rig (each left image given as its own right) is refused
// with its figures, not stored with a baseline of nanometres.
TEST_F(SamplePairsTest, DegenerateRigIsRefusedWithItsFigures) {
    std::vector<ImagePair> same;
    for (std::size_t i = 0; i < 8; ++i) same.push_back({pairs_[i].left, pairs_[i].left});
    const auto result = CalibrateFromChessboards(same, kBoard);
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kFailedPrecondition,
                         "degenerate rig: baseline"))
        << (result.ok() ? std::to_string(result->baseline_m) : "");
}

TEST_F(SamplePairsTest, TooFewPairsListsTheSkipReasons) {
    std::vector<ImagePair> pairs(pairs_.begin(), pairs_.begin() + 4);
    pairs.push_back({"garbage", pairs_[5].right});
    pairs.push_back({"garbage", pairs_[6].right});
    const auto result = CalibrateFromChessboards(pairs, kBoard);
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kFailedPrecondition,
                         "4 usable chessboard pairs of 6, 5 needed; skipped: "
                         "2 x left: not a decodable image"));
}

TEST_F(SamplePairsTest, BadPairsAreSkippedWithTheirReason) {
    const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(128));
    std::vector<uchar> blank_png;
    cv::imencode(".png", blank, blank_png);
    std::vector<ImagePair> pairs(pairs_.begin(), pairs_.begin() + 5);
    pairs.push_back({"garbage bytes", pairs_[5].right});
    pairs.push_back({pairs_[6].left, ReencodePng(pairs_[6].right, cv::ROTATE_90_CLOCKWISE)});
    pairs.push_back({ReencodePng(pairs_[7].left, cv::ROTATE_90_CLOCKWISE),
                     ReencodePng(pairs_[7].right, cv::ROTATE_90_CLOCKWISE)});
    pairs.push_back({std::string(blank_png.begin(), blank_png.end()), pairs_[8].right});
    pairs.push_back({pairs_[9].left, ReencodePng(pairs_[9].right, -1)});  // PNG mixes with JPEG

    const auto result = CalibrateFromChessboards(pairs, kBoard);
    ASSERT_TRUE(result.ok()) << result.status();
    ASSERT_EQ(result->skipped.size(), 4u);
    EXPECT_EQ(result->skipped[0].index, 5);
    EXPECT_EQ(result->skipped[0].reason,
              "left: not a decodable image (PNG, JPEG, BMP, PNM or TIFF)");
    EXPECT_EQ(result->skipped[1].index, 6);
    EXPECT_EQ(result->skipped[1].reason, "left is 640x480 but right is 480x640");
    EXPECT_EQ(result->skipped[2].index, 7);
    EXPECT_EQ(result->skipped[2].reason,
              "size 480x640 differs from the first usable pair's 640x480");
    EXPECT_EQ(result->skipped[3].index, 8);
    EXPECT_EQ(result->skipped[3].reason, "left: chessboard 9x6 not found");
    ASSERT_EQ(result->pairs.size(), 6u);
    EXPECT_EQ(result->pairs[5].index, 9);
    EXPECT_LE(result->rms_reprojection_px, kMaxRmsPx);
}

TEST_F(SamplePairsTest, OversizeImageIsInvalidArgumentNamingThePair) {
    CalibrationConfig config;
    config.max_image_side_px = 600;
    const auto result = CalibrateFromChessboards(pairs_, kBoard, config);
    EXPECT_TRUE(IsInvalidWith(result, "pair 0: left: 640x480 is larger than 600 px"));
}

TEST_F(SamplePairsTest, WorseFitThanAllowedIsFailedPrecondition) {
    CalibrationConfig config;
    config.max_rms_px = 0.05;
    const auto result = CalibrateFromChessboards(pairs_, kBoard, config);
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kFailedPrecondition,
                         "exceeds max_rms_px 0.05"));
}

// A token that can stop runs each board search on a thread of its own: while it never stops,
// the calibration is the same to the last bit.
TEST_F(SamplePairsTest, NeverStoppingTokenChangesNothing) {
    ASSERT_TRUE(Calibrated());
    const CountingStop never(0);
    const auto result = CalibrateFromChessboards(pairs_, kBoard, {}, never.token());
    ASSERT_TRUE(result.ok()) << result.status();
    EXPECT_EQ(result->baseline_m, Calibration().baseline_m);
    EXPECT_EQ(result->rms_reprojection_px, Calibration().rms_reprojection_px);
    EXPECT_EQ(result->Q, Calibration().Q);
    // Looks before and after each pair and before each of its two searches (more while a
    // search runs longer than a poll), then one before each of the five stages after them.
    EXPECT_GE(never.looks(), 4 * 13 + 5);
}

TEST_F(SamplePairsTest, ExpiredDeadlineIsDeadlineExceededBeforeTheFirstPair) {
    const StopToken expired(StopToken::Clock::now() - std::chrono::seconds(1));
    const auto result = CalibrateFromChessboards(pairs_, kBoard, {}, expired);
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kDeadlineExceeded,
                         "deadline expired during chessboard detection (pair 1 of 13)"));
}

// The case: the caller goes away while the boards are searched; the call ends there
// instead of searching the remaining pairs and fitting.
TEST_F(SamplePairsTest, CancelAtTheThirdLookStopsInTheFirstPair) {
    const CountingStop cancel(3);
    const auto result = CalibrateFromChessboards(pairs_, kBoard, {}, cancel.token());
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kCancelled,
                         "cancelled during chessboard detection (pair 1 of 13)"));
    EXPECT_EQ(cancel.looks(), 3);
}

// Wherever the caller goes away (a search, a fit, rectification, the figures), the call ends
// cancelled: never with a result, nor with an error a half-done stage would give. Searches
// longer than a poll only add looks, so every look up to 4 x 13 + 5 is reached.
TEST_F(SamplePairsTest, CancelAtAnyLookIsCancelled) {
    for (const long look : {1L, 2L, 4L, 10L, 25L, 50L, 52L, 53L, 54L, 55L, 56L, 57L}) {
        const CountingStop cancel(look);
        const auto result = CalibrateFromChessboards(pairs_, kBoard, {}, cancel.token());
        EXPECT_EQ(result.status().code(), absl::StatusCode::kCancelled)
            << "look " << look << ": " << result.status();
    }
}

// Pairs beyond max_fit_pairs are left out of the fits and judged against their result.
TEST_F(SamplePairsTest, PairsBeyondTheFitLimitAreJudgedAgainstTheFit) {
    ASSERT_TRUE(Calibrated());
    CalibrationConfig config;
    config.max_fit_pairs = 7;
    const auto result = CalibrateFromChessboards(pairs_, kBoard, config);
    ASSERT_TRUE(result.ok()) << result.status();
    ASSERT_EQ(result->pairs.size(), 13u);
    int fitted = 0;
    for (const PairError& pair : result->pairs) {
        fitted += pair.fitted;
        EXPECT_GT(pair.rms_px, 0.0);
        EXPECT_LT(pair.rms_px, 2.0 * kMaxRmsPx) << pair.index;
        EXPECT_LT(pair.epipolar_px, kMaxRmsPx) << pair.index;
    }
    EXPECT_EQ(fitted, 7);
    EXPECT_TRUE(result->pairs.front().fitted);  // spread evenly from the first
    EXPECT_NEAR(result->baseline_m, kSampleBaselineSquares, kBaselineTolerance);
    EXPECT_LE(result->rms_reprojection_px, kMaxRmsPx);
    for (const PairError& pair : Calibration().pairs) EXPECT_TRUE(pair.fitted);
}

// A small BMP whose header declares `width` x `height` (BMP headers carry no checksum).
std::string BmpClaiming(std::int32_t width, std::int32_t height) {
    std::vector<uchar> bytes;
    cv::imencode(".bmp", cv::Mat(8, 8, CV_8UC1, cv::Scalar(90)), bytes);
    std::string bmp(bytes.begin(), bytes.end());
    for (int i = 0; i < 4; ++i) {
        bmp[static_cast<std::size_t>(18 + i)] = static_cast<char>(width >> (8 * i));
        bmp[static_cast<std::size_t>(22 + i)] = static_cast<char>(height >> (8 * i));
    }
    return bmp;
}

// Issue 12: 200 pairs with a 10 s deadline ran 359 s. The work a call asks for is bounded from
// the headers, before any image is decoded or searched for corners.
TEST(CalibrationBudgetTest, TooManyPairsOrPixelsAreRefusedBeforeDecoding) {
    const std::string small = BmpClaiming(8, 8);
    const std::vector<ImagePair> many(201, ImagePair{small, small});
    const auto too_many = CalibrateFromChessboards(many, kBoard);
    EXPECT_TRUE(HasError(too_many.status(), absl::StatusCode::kInvalidArgument,
                         "pairs: at most 200 pairs, got 201"));
    // Four pairs declaring 8000 x 8000 each: 512 million pixels.
    const std::string big = BmpClaiming(8000, 8000);
    const std::vector<ImagePair> huge(4, ImagePair{big, big});
    const auto too_big = CalibrateFromChessboards(huge, kBoard);
    EXPECT_TRUE(HasError(too_big.status(), absl::StatusCode::kInvalidArgument,
                         "pairs: 512000000 pixels in all; at most 500000000"));
}

TEST(CalibrateFromChessboardsTest, BadBoardOrConfigIsInvalidArgument) {
    const std::vector<ImagePair> none;
    EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, {1, 6, 0.025}), "board.cols"));
    EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, {9, 1, 0.025}), "board.rows"));
    EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, {9, 1000, 0.025}), "board.rows"));
    for (const double square : {0.0, -0.025, kNan, kInf}) {
        EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, {9, 6, square}),
                                  "board.square_size_m must be positive and finite"));
    }
    CalibrationConfig config;
    config.max_rms_px = kNan;
    EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, kBoard, config), "max_rms_px"));
    config = {};
    config.max_image_side_px = 100000;
    EXPECT_TRUE(IsInvalidWith(CalibrateFromChessboards(none, kBoard, config), "max_image_side_px"));
}

TEST(CalibrateFromChessboardsTest, SquareBoardIsAllowed) {
    const auto result = CalibrateFromChessboards({}, {7, 7, 0.03});
    EXPECT_TRUE(HasError(result.status(), absl::StatusCode::kFailedPrecondition,
                         "0 usable chessboard pairs of 0"));
}

}  // namespace
}  // namespace soilvol::stereo
