#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/common/timer.hpp"
#include "core/sim/chessboard_target.hpp"
#include "core/sim/pinhole_camera.hpp"
#include "core/sim/stereo_renderer.hpp"

namespace soilvol::sim {
namespace {

constexpr int kCols = 9;
constexpr int kRows = 6;
constexpr double kSquareM = 0.04;

const std::vector<ChessboardView>& Views() {
    static const std::vector<ChessboardView> views = [] {
        StereoRigSpec rig;
        rig.pixel_noise_sigma = 0.0;
        Timer timer;
        std::vector<ChessboardView> rendered = RenderChessboards(rig, kCols, kRows, kSquareM, 6, 3);
        std::printf("chessboard_views=%zu width=640 height=480 render_ms=%.0f\n", rendered.size(),
                    timer.Lap());
        return rendered;
    }();
    return views;
}

bool InsideWithMargin(const Eigen::Vector2d& px, double margin) {
    return px.x() >= margin && px.y() >= margin && px.x() <= 639 - margin && px.y() <= 479 - margin;
}

// Grey level at the pixel nearest to the centre of board square (a, b), a in [0, cols].
int SquareCentreGrey(const ChessboardView& view, int a, int b) {
    const Eigen::Vector3d centre((a - 0.5) * kSquareM, (b - 0.5) * kSquareM, 0.0);
    const Eigen::Vector2d px = ProjectLeft(StereoRigSpec(), view.T_left_board * centre);
    return view.left.At(static_cast<int>(std::lround(px.x())),
                        static_cast<int>(std::lround(px.y())));
}

TEST(ChessboardRendererTest, AllViewsShowEveryCornerInBothImages) {
    const std::vector<ChessboardView>& views = Views();
    ASSERT_EQ(views.size(), 6u);
    Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
    for (const ChessboardView& view : views) {
        ASSERT_EQ(view.corners_left_px.size(), static_cast<size_t>(kCols * kRows));
        ASSERT_EQ(view.corners_right_px.size(), static_cast<size_t>(kCols * kRows));
        ASSERT_EQ(view.left.pixels.size(), 640u * 480u);
        for (int i = 0; i < kCols * kRows; ++i) {
            EXPECT_TRUE(InsideWithMargin(view.corners_left_px[i], 20.0));
            EXPECT_TRUE(InsideWithMargin(view.corners_right_px[i], 20.0));
            lo = lo.cwiseMin(view.corners_left_px[i]);
            hi = hi.cwiseMax(view.corners_left_px[i]);
        }
        const double distance = view.T_left_board.translation().norm();
        EXPECT_GT(distance, 0.5);
        EXPECT_LT(distance, 1.8);
    }
    // Corners spread over most of the image.
    EXPECT_LT(lo.x(), 200.0);
    EXPECT_GT(hi.x(), 440.0);
    EXPECT_LT(lo.y(), 150.0);
    EXPECT_GT(hi.y(), 330.0);
}

TEST(ChessboardRendererTest, SquaresAreBlackAndWhiteWhereTheyProject) {
    for (const ChessboardView& view : Views()) {
        EXPECT_LT(SquareCentreGrey(view, 0, 0), 40);  // top-left square is black
        EXPECT_GT(SquareCentreGrey(view, 1, 0), 150);
        EXPECT_GT(SquareCentreGrey(view, 0, 1), 150);
        EXPECT_GT(SquareCentreGrey(view, kCols, kRows), 150);  // 10 x 7 squares
        EXPECT_LT(SquareCentreGrey(view, 0, kRows), 40);
        EXPECT_GT(SquareCentreGrey(view, -1, 2), 150);  // white ring
    }
}

TEST(ChessboardRendererTest, CornersRunRowByRowFromTheTopLeft) {
    for (const ChessboardView& view : Views()) {
        const std::vector<Eigen::Vector2d>& c = view.corners_left_px;
        for (int j = 0; j < kRows; ++j) {
            const Eigen::Vector2d along = c[j * kCols + kCols - 1] - c[j * kCols];
            EXPECT_GT(along.x(), std::abs(along.y()));  // rows run to the right
            for (int i = 0; i + 1 < kCols; ++i) {
                const Eigen::Vector2d step = c[j * kCols + i + 1] - c[j * kCols + i];
                EXPECT_GT(step.dot(along.normalized()), 0.5 * along.norm() / (kCols - 1));
            }
        }
        const Eigen::Vector2d down = c[(kRows - 1) * kCols] - c[0];
        EXPECT_GT(down.y(), std::abs(down.x()));  // then down the image
    }
}

TEST(ChessboardRendererTest, EdgePixelsMatchBruteForceCoverage) {
    // Exact pixel coverage: compare straddling pixels (every other row) with 16 x 16 rays per
    // pixel through the true camera model (sampling error up to 1/32 of the contrast, 6 levels).
    const StereoRigSpec rig;
    const std::array<PinholeCamera, 2> cameras = RigCameras(rig);
    const ChessboardView& view = Views()[0];
    const Pose T_board_left = view.T_left_board.inverse();
    const Eigen::Vector3d normal = view.T_left_board.linear().col(2);
    constexpr int kSamples = 16;
    for (int camera_index = 0; camera_index < 2; ++camera_index) {
        const PinholeCamera& camera = cameras[camera_index];
        const GreyImage& image = camera_index == 0 ? view.left : view.right;
        const Eigen::Vector3d origin = T_board_left * camera.Centre();
        double sum_error = 0.0;
        int pixels = 0;
        for (int v = 0; v < 480; v += 2) {
            for (int u = 0; u < 640; ++u) {
                const int grey = image.At(u, v);
                if (grey < 50 || grey > 150) continue;
                double sum = 0.0;
                bool on_squares = true;
                const double shade =
                    0.8 + 0.2 * std::abs(normal.dot(camera.Direction(Eigen::Vector2d(u, v))));
                for (int j = 0; j < kSamples && on_squares; ++j) {
                    for (int i = 0; i < kSamples; ++i) {
                        const Eigen::Vector3d d =
                            T_board_left.linear() *
                            camera.Direction(Eigen::Vector2d(u - 0.5 + (i + 0.5) / kSamples,
                                                             v - 0.5 + (j + 0.5) / kSamples));
                        const Eigen::Vector3d p = origin - origin.z() / d.z() * d;
                        const int a = static_cast<int>(std::floor(p.x() / kSquareM)) + 1;
                        const int b = static_cast<int>(std::floor(p.y() / kSquareM)) + 1;
                        on_squares = on_squares && a >= 0 && a <= kCols && b >= 0 && b <= kRows;
                        sum += (a + b) % 2 == 0 ? ChessboardTarget::kBlackAlbedo
                                                : ChessboardTarget::kWhiteAlbedo;
                    }
                }
                if (!on_squares) continue;
                const double expected = 255.0 * shade * sum / (kSamples * kSamples);
                ASSERT_NEAR(grey, expected, 6.0) << u << " " << v;
                sum_error += std::abs(grey - expected);
                ++pixels;
            }
        }
        ASSERT_GT(pixels, 300);
        EXPECT_LT(sum_error / pixels, 1.0);
    }
}

TEST(ChessboardRendererTest, HostileRequestsGiveNoViews) {
    const StereoRigSpec rig;
    EXPECT_TRUE(RenderChessboards(rig, 9, 6, 0.04, 0, 1).empty());
    EXPECT_TRUE(RenderChessboards(rig, 1, 6, 0.04, 2, 1).empty());
    EXPECT_TRUE(RenderChessboards(rig, 9, 6, -0.04, 2, 1).empty());
    EXPECT_TRUE(RenderChessboards(rig, 9, 6, 0.5, 2, 1).empty());  // 6 m board never fits
    StereoRigSpec empty = rig;
    empty.image_width = 0;
    EXPECT_TRUE(RenderChessboards(empty, 9, 6, 0.04, 2, 1).empty());
}

}  // namespace
}  // namespace soilvol::sim
