// RenderChessboards (declared in stereo_renderer.hpp): calibration views, anti-aliased by the
// exact area of each pixel's footprint on the board plane.
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "core/sim/chessboard_target.hpp"
#include "core/sim/image_sensor.hpp"
#include "core/sim/pinhole_camera.hpp"
#include "core/sim/procedural_texture.hpp"
#include "core/sim/stereo_renderer.hpp"

namespace soilvol::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
constexpr double kMarginPx = 20.0;
constexpr double kMaxTiltDeg = 35.0;
constexpr double kMaxRollDeg = 15.0;
constexpr double kMaxObliquityDeg = 60.0;
constexpr double kMinDistanceM = 0.6;
constexpr double kMaxDistanceM = 1.6;
constexpr int kDrawsPerCell = 300;
constexpr int kMaxDraws = 3000;
constexpr double kExposure = 255.0;

// Rays through the pixel corners (u - 0.5, v - 0.5), (width + 1) x (height + 1), row-major.
struct CornerRays {
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // left frame
    std::vector<Eigen::Vector3d> directions;           // left frame
};

CornerRays PixelCornerRays(const PinholeCamera& camera, int width, int height) {
    CornerRays rays;
    rays.origin = camera.Centre();
    rays.directions.resize(static_cast<size_t>(width + 1) * static_cast<size_t>(height + 1));
#pragma omp parallel for schedule(static)
    for (int v = 0; v <= height; ++v) {
        for (int u = 0; u <= width; ++u) {
            rays.directions[static_cast<size_t>(v) * (width + 1) + u] =
                camera.Direction(Eigen::Vector2d(u - 0.5, v - 0.5));
        }
    }
    return rays;
}

// Board-plane coordinates where the ray meets the plane in front of the camera, or NaN.
Eigen::Vector2d OnBoard(const Pose& T_board_left, const Eigen::Vector3d& origin,
                        const Eigen::Vector3d& direction) {
    const Eigen::Vector3d o = T_board_left * origin;
    const Eigen::Vector3d d = T_board_left.linear() * direction;
    const double t = std::abs(d.z()) > 1e-12 ? -o.z() / d.z() : -1.0;
    if (!(t > 0.0)) return Eigen::Vector2d::Constant(std::nan(""));
    return o.head<2>() + t * d.head<2>();
}

// Grey levels of one view: each pixel's footprint on the board plane (its corner rays) split
// exactly into black, white and off-board shares; off the board the backdrop at infinity.
std::vector<double> RenderBoard(const ChessboardTarget& board, const Pose& T_left_board,
                                const CornerRays& rays, int width, int height) {
    const Pose T_board_left = T_left_board.inverse();
    const Eigen::Vector3d normal = T_left_board.linear().col(2);
    const size_t stride = static_cast<size_t>(width) + 1;
    std::vector<double> grey(static_cast<size_t>(width) * static_cast<size_t>(height));
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < height; ++v) {
        std::vector<Eigen::Vector2d> corners(2 * stride);
        for (size_t k = 0; k < corners.size(); ++k) {
            corners[k] = OnBoard(T_board_left, rays.origin, rays.directions[v * stride + k]);
        }
        for (int u = 0; u < width; ++u) {
            const std::vector<Eigen::Vector2d> footprint = {
                corners[u], corners[u + 1], corners[stride + u + 1], corners[stride + u]};
            const Eigen::Vector3d centre_ray =
                (rays.directions[v * stride + u] + rays.directions[(v + 1) * stride + u + 1])
                    .normalized();
            const bool on_plane =
                std::all_of(footprint.begin(), footprint.end(),
                            [](const Eigen::Vector2d& p) { return p.allFinite(); });
            BoardCoverage coverage;
            if (on_plane) {
                coverage = board.Cover(footprint);
            } else {
                coverage.off_board = 1.0;
            }
            const double shade = 0.8 + 0.2 * std::abs(normal.dot(centre_ray));
            double value = shade * (coverage.black * ChessboardTarget::kBlackAlbedo +
                                    coverage.white * ChessboardTarget::kWhiteAlbedo);
            if (coverage.off_board > 0.0)
                value += coverage.off_board * BackdropRadiance(centre_ray);
            grey[static_cast<size_t>(v) * width + u] = kExposure * value;
        }
    }
    return grey;
}

bool InsideWithMargin(const Eigen::Vector2d& px, int width, int height) {
    return px.allFinite() && px.x() >= kMarginPx && px.y() >= kMarginPx &&
           px.x() <= width - 1 - kMarginPx && px.y() <= height - 1 - kMarginPx;
}

// Board pose whose centre is seen at `target_px` at `distance_m`, tilted and rolled at random.
Pose DrawPose(const ChessboardTarget& board, const PinholeCamera& left,
              const Eigen::Vector2d& target_px, double distance_m, std::mt19937_64* rng) {
    std::uniform_real_distribution<double> tilt(-kMaxTiltDeg * kDegToRad, kMaxTiltDeg * kDegToRad);
    std::uniform_real_distribution<double> roll(-kMaxRollDeg * kDegToRad, kMaxRollDeg * kDegToRad);
    const double about_x = tilt(*rng);
    const double about_y = tilt(*rng);
    const double about_z = roll(*rng);
    Pose T = Pose::Identity();
    T.linear() = (Eigen::AngleAxisd(about_z, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(about_x, Eigen::Vector3d::UnitX()) *
                  Eigen::AngleAxisd(about_y, Eigen::Vector3d::UnitY()))
                     .toRotationMatrix();
    T.translation() = distance_m * left.Direction(target_px) - T.linear() * board.Centre();
    return T;
}

// Whole board with its ring inside both images with the margin, seen at most kMaxObliquityDeg
// off its normal.
bool FullyVisible(const ChessboardTarget& board, const Pose& T_left_board,
                  const std::array<PinholeCamera, 2>& cameras, int width, int height) {
    const Eigen::Vector3d centre = T_left_board * board.Centre();
    const std::vector<Eigen::Vector3d> outline = board.Outline(16);
    for (const PinholeCamera& camera : cameras) {
        const Eigen::Vector3d line_of_sight = (centre - camera.Centre()).normalized();
        if (std::abs(line_of_sight.dot(T_left_board.linear().col(2))) <
            std::cos(kMaxObliquityDeg * kDegToRad)) {
            return false;
        }
        for (const Eigen::Vector3d& p : outline) {
            if (!InsideWithMargin(camera.Project(T_left_board * p), width, height)) return false;
        }
    }
    return true;
}

}  // namespace

std::vector<ChessboardView> RenderChessboards(const StereoRigSpec& rig, int cols, int rows,
                                              double square_size_m, int count, uint64_t seed) {
    std::vector<ChessboardView> views;
    const int width = rig.image_width;
    const int height = rig.image_height;
    if (count <= 0 || cols < 2 || rows < 2 || !(square_size_m > 0.0) || width <= 0 || height <= 0) {
        return views;
    }
    const ChessboardTarget board(cols, rows, square_size_m);
    const std::array<PinholeCamera, 2> cameras = RigCameras(rig);
    const CornerRays rays[2] = {PixelCornerRays(cameras[0], width, height),
                                PixelCornerRays(cameras[1], width, height)};

    // Distances at which the board (with its ring) spans 45-85 % of the image width.
    const double focal = RigParameters(rig).left.fx;
    const double board_width = (std::max(cols, rows) + 3) * square_size_m;
    const double near =
        std::clamp(focal * board_width / (0.85 * width), kMinDistanceM, kMaxDistanceM);
    const double far = std::clamp(focal * board_width / (0.45 * width), near, kMaxDistanceM);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    // Board centres spread over a shuffled 3 x 3 grid of image cells, anywhere if that fails.
    std::vector<int> cells(9);
    std::iota(cells.begin(), cells.end(), 0);
    std::shuffle(cells.begin(), cells.end(), rng);

    for (int k = 0; k < count; ++k) {
        Pose T_left_board = Pose::Identity();
        bool found = false;
        for (int draw = 0; draw < kMaxDraws && !found; ++draw) {
            const int cell = cells[k % 9];
            const bool in_cell = draw < kDrawsPerCell;
            const double cu = in_cell ? (cell % 3 + unit(rng)) / 3.0 : unit(rng);
            const double cv = in_cell ? (cell / 3 + unit(rng)) / 3.0 : unit(rng);
            const Eigen::Vector2d target(cu * (width - 1), cv * (height - 1));
            const double distance = near + (far - near) * unit(rng);
            T_left_board = DrawPose(board, cameras[0], target, distance, &rng);
            found = FullyVisible(board, T_left_board, cameras, width, height);
        }
        if (!found) continue;

        ChessboardView view;
        view.T_left_board = T_left_board;
        for (int j = 0; j < rows; ++j) {
            for (int i = 0; i < cols; ++i) {
                const Eigen::Vector3d corner = T_left_board * board.Corner(i, j);
                view.corners_left_px.push_back(cameras[0].Project(corner));
                view.corners_right_px.push_back(cameras[1].Project(corner));
            }
        }
        const uint64_t stream = 2 * static_cast<uint64_t>(k);
        view.left = ExposeImage(RenderBoard(board, T_left_board, rays[0], width, height), width,
                                height, rig.pixel_noise_sigma, seed, stream + 1);
        view.right = ExposeImage(RenderBoard(board, T_left_board, rays[1], width, height), width,
                                 height, rig.pixel_noise_sigma, seed, stream + 2);
        views.push_back(std::move(view));
    }
    return views;
}

}  // namespace soilvol::sim
