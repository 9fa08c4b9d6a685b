#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "absl/status/status.h"
#include "core/common/polygon.hpp"
#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"

namespace soilvol::align {

/// ICP of the model's outside (source) onto a new scan (target), paper Sec. 3.3. Point-to-plane
/// Gauss-Newton with the model's normals; the paper's values are the defaults.
struct AlignConfig {
    int max_iterations = 200;                 ///< paper: 200
    double max_correspondence_m = 0.05;       ///< paper: 0.05 m
    double ransac_outlier_rejection_m = 1.0;  ///< paper: 1; residuals above it are rejected
    double transformation_epsilon = 1e-8;     ///< paper: 1e-8; squared step [m^2, rad^2] to stop
    /// Nearest-neighbour correspondences can make the last steps cycle instead of shrinking: the
    /// fit has also converged when the pose moved less than these over the last
    /// `plateau_iterations` iterations.
    double plateau_translation_m = 1e-3;
    double plateau_rotation_rad = 1e-3;
    int plateau_iterations = 4;
    /// ... or when its cost (mean squared point-to-plane residual) fell by less than this share
    /// over the last `cost_iterations` iterations.
    double cost_decrease = 1e-3;
    int cost_iterations = 5;
    /// A first stage at this correspondence distance catches pose changes larger than the
    /// paper's 5 cm before the fine stage; 0 = paper only.
    double coarse_max_correspondence_m = 0.20;
    /// The scan is voxel-averaged and smoothed exactly as the model's alignment set was
    /// (ModelConfig), so that noise blurs both alike: nearest-neighbour correspondences on a raw
    /// noisy scan follow the noise and leave the pose biased.
    double target_voxel_m = 0.03;
    double smoothing_radius_m = 0.08;  ///< 0 = off
    double crop_margin_m = 0.30;       ///< scan cropped to the model's extent plus this margin
    /// Correspondences whose normals differ by more than this are rejected (with smoothing).
    double max_normal_angle_deg = 45.0;
    /// How far inside the contents' column each stage keeps the scan's returns: the coarse
    /// stage as far as the pose can be off, the fine one a voxel's width.
    double coarse_column_margin_m = 0.10;
    double fine_column_margin_m = 0.0;
    int num_threads = 0;  ///< 0 = all cores
};

/// Refuses a volume from a bad alignment. No share of matched points decides alone: a heap
/// hides much of a container's outside from a sensor above it. The alignment must rest on
/// enough matches that pin every direction of the pose; whether the pose agrees with the
/// contents is judged after the volume (pipeline::EstimateVolume).
struct AlignGate {
    std::size_t min_correspondences =
        40;                     ///< model points with a scan point within the fine distance
    double min_fitness = 0.05;  ///< share of those: below it the scan lost the container
    double max_rmse_m = 0.05;   ///< point-to-plane RMS of the correspondences
    /// Largest 1-sigma of the position and of the orientation from the fit (its covariance
    /// counts the residuals' correlation; these are the former 5 cm / 3 deg on the covariance
    /// that took every residual as independent, 4.7 times narrower in sigma at the defaults).
    double max_translation_sigma_m = 0.24;
    double max_rotation_sigma_deg = 14.0;
    bool require_converged = true;
};

/// Where a container's contents can be, in its own frame: over the opening polygon and below
/// `top_m`, and the inner walls, within `wall_band_m` of the polygon's edge and more than that
/// below the opening (soil covers both). Returns there are left out of an alignment's target,
/// but for a band `margin_m` wide inside the polygon's edge above the walls: with the pose
/// still uncertain by that much, a wider cut would take the rim on one side.
struct ContentColumn {
    Polygon2d polygon;
    double top_m = 0.05;
    double wall_band_m = 0.05;
    double margin_m = 0.0;
    /// What the polygon says of a point's (x, y).
    struct Side {
        bool inside = false;
        bool near_wall = false;      ///< within wall_band_m of the edge
        bool beyond_margin = false;  ///< farther than margin_m from the edge (or no margin)
    };
    Side SideOf(const Eigen::Vector2d& xy) const;

    bool Holds(const Eigen::Vector3d& p) const {
        return Holds(p, [this](const Eigen::Vector2d& xy) { return SideOf(xy); });
    }
    /// The rule, heights first: `side` answers for the polygon only where the heights leave
    /// it open.
    template <class SideFn>
    bool Holds(const Eigen::Vector3d& p, const SideFn& side) const {
        const bool low = p.z() < -wall_band_m;
        const bool under_top = p.z() < top_m;
        if (!low && !under_top) return false;
        const Side s = side(Eigen::Vector2d(p.head<2>()));
        if (low && (s.inside || s.near_wall)) return true;
        return s.inside && under_top && s.beyond_margin;
    }
};

/// ContentColumn::Holds with the same answers at a fraction of the cost (every return of a scan
/// asks): the polygon's side is looked up in a raster of cells that lie wholly on one side of
/// the edge and of each edge-distance threshold (the distance to the edge changes by at most a
/// cell's half diagonal within it); only points in the other cells ask the polygon.
class ContentColumnIndex {
  public:
    explicit ContentColumnIndex(ContentColumn column);
    bool Holds(const Eigen::Vector3d& p) const;

  private:
    ContentColumn column_;
    Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
    double cell_m_ = 1.0;
    int cols_ = 0, rows_ = 0;
    std::vector<uint8_t> cells_;  // 0: ask the polygon; else 1 | the side's bits
};

struct AlignResult {
    Pose T_scan_container = Pose::Identity();  ///< the container in the new scan
    bool converged = false;
    int iterations = 0;
    double fitness = 0.0;  ///< share of source points with a correspondence (fine distance)
    double rmse_m = 0.0;   ///< point-to-plane RMS of the correspondences
    std::size_t correspondences = 0;
    double z_sigma_m = 0.0;  ///< 1-sigma of the opening's offset along its normal, from the fit
    /// Covariance of the pose [rad^2, m^2]: left perturbation (rotation, translation) in the
    /// scan frame, rmse^2 times the inverse Gauss-Newton Hessian times the number of alignment
    /// points whose residuals share one smoothing disc's returns.
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
    std::size_t target_points = 0;
};

/// Aligns `source` (container frame, with unit `normals`) to `scan` (scan frame), starting at
/// `initial_T_scan_container`; scan returns in `column` (when given) are not container. On a
/// `stop` it returns the pose reached so far, not converged and without the fit's figures.
AlignResult Align(const Cloud& source, const Cloud& normals, const Cloud& scan,
                  const Pose& initial_T_scan_container, const AlignConfig& config,
                  const ContentColumn* column = nullptr, const StopToken& stop = {});

/// FailedPrecondition naming the figures when `result` does not pass `gate`.
absl::Status CheckAlignment(const AlignResult& result, const AlignGate& gate);

}  // namespace soilvol::align
