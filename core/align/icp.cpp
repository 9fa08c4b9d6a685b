#include "core/align/icp.hpp"

#include <omp.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/cloud/kd_tree.hpp"
#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/angles.hpp"

namespace soilvol::align {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

struct System {
    Matrix6d H = Matrix6d::Zero();
    Vector6d g = Vector6d::Zero();
    double sq_sum = 0.0;
    std::size_t count = 0;
};

struct Target {
    Cloud points;
    Cloud normals;  // unit, empty without smoothing
};

// The scan points near the model at pose `initial`, outside the contents' column, voxel-averaged
// and smoothed among themselves: what the container holds never blends into its outside.
Target PrepareTarget(const Cloud& source, const Cloud& scan, const Pose& initial,
                     const AlignConfig& config, const ContentColumn* column, double voxel_m,
                     const StopToken& stop) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (const auto& p : source) centre += p.cast<double>();
    centre /= static_cast<double>(std::max<std::size_t>(source.size(), 1));
    double radius = 0.0;
    for (const auto& p : source) radius = std::max(radius, (p.cast<double>() - centre).norm());
    const Eigen::Vector3f c = (initial * centre).cast<float>();
    const auto r2 = static_cast<float>(std::pow(radius + config.crop_margin_m, 2));
    const Pose to_container = initial.inverse();
    const std::optional<ContentColumnIndex> index =
        column != nullptr ? std::optional<ContentColumnIndex>(*column) : std::nullopt;
    Cloud cropped;
    cropped.reserve(scan.size());
    for (const auto& p : scan) {
        if ((p - c).squaredNorm() > r2) continue;
        if (index && index->Holds((to_container * p.cast<double>()))) continue;
        cropped.push_back(p);
    }
    if (stop.StopRequested()) return {};
    if (config.smoothing_radius_m <= 0.0) return {cloud::VoxelDownsample(cropped, voxel_m), {}};
    // Each voxel weighs by its returns: the means are the points' own at any scan density.
    const cloud::VoxelCentroids voxels = cloud::CentroidsOf(cropped, voxel_m);
    cloud::LocalSurface surface = cloud::SmoothLocalSurface(
        voxels.points, voxels.counts, config.smoothing_radius_m, cloud::kMinSurfaceNeighbors, stop);
    return {std::move(surface.points), std::move(surface.normals)};
}

// Point-to-plane normal equations at pose T: r = n'.(T p - q), left perturbation (w, t).
// Pairs whose normals differ by more than acos(min_normal_cos) are different surfaces met at
// an edge (a rim's top and the wall below it), not one surface seen twice.
System Linearize(const Cloud& source, const Cloud& normals, const Pose& T, const Target& target,
                 const cloud::KdTree& tree, double max_dist, double max_residual,
                 double min_normal_cos, int threads) {
    System total;
    const Eigen::Matrix3f R = T.linear().cast<float>();
    const Eigen::Vector3f t = T.translation().cast<float>();
    const auto max_d2 = static_cast<float>(max_dist * max_dist);
#pragma omp parallel num_threads(threads)
    {
        System local;
#pragma omp for schedule(static) nowait
        for (long i = 0; i < static_cast<long>(source.size()); ++i) {
            const auto k = static_cast<std::size_t>(i);
            const Eigen::Vector3f p = R * source[k] + t;
            const auto [j, d2] = tree.Nearest(p);
            if (j < 0 || d2 > max_d2) continue;
            const Eigen::Vector3d n = (R * normals[k]).cast<double>();
            const auto tj = static_cast<std::size_t>(j);
            if (!target.normals.empty() &&
                std::abs(n.dot(target.normals[tj].cast<double>())) < min_normal_cos) {
                continue;
            }
            const Eigen::Vector3d pd = p.cast<double>();
            const double r = n.dot(pd - target.points[tj].cast<double>());
            if (std::abs(r) > max_residual) continue;
            Vector6d J;
            J << pd.cross(n), n;
            local.H.noalias() += J * J.transpose();
            local.g.noalias() += J * r;
            local.sq_sum += r * r;
            ++local.count;
        }
#pragma omp critical
        {
            total.H += local.H;
            total.g += local.g;
            total.sq_sum += local.sq_sum;
            total.count += local.count;
        }
    }
    return total;
}

// True when the pose moved less than the plateau bounds over the last plateau_iterations steps.
bool Settled(const std::vector<Pose>& history, const AlignConfig& config) {
    const auto k = static_cast<std::size_t>(std::max(config.plateau_iterations, 1));
    if (history.size() <= k) return false;
    const Pose delta = history[history.size() - 1 - k].inverse() * history.back();
    return delta.translation().norm() < config.plateau_translation_m &&
           Eigen::AngleAxisd(delta.linear()).angle() < config.plateau_rotation_rad;
}

// True when the best cost of the last `cost_iterations` iterations is no lower than the best
// before them by more than the relative `cost_decrease`.
bool CostSettled(const std::vector<double>& costs, const AlignConfig& config) {
    const auto k = static_cast<std::size_t>(std::max(config.cost_iterations, 1));
    if (costs.size() <= k) return false;
    const double before = *std::min_element(costs.begin(), costs.end() - static_cast<long>(k));
    const double recent = *std::min_element(costs.end() - static_cast<long>(k), costs.end());
    return recent >= before * (1.0 - config.cost_decrease);
}

Pose Exp(const Vector6d& xi) {
    Pose step = Pose::Identity();
    const double angle = xi.head<3>().norm();
    if (angle > 1e-12) {
        step.linear() = Eigen::AngleAxisd(angle, xi.head<3>() / angle).toRotationMatrix();
    }
    step.translation() = xi.tail<3>();
    return step;
}

// How many alignment points share one residual's noise. Each correspondence's target is the
// scan smoothed over `smoothing_radius_m`, so the residuals of the alignment points within one
// smoothing disc carry the same averaged returns: for a uniform kernel the integral of the
// residuals' correlation over the surface is the disc's area, and the pose's variance is
// rmse^2 H^-1 (every residual independent) times the independent points one disc holds. That
// is the disc's area over a voxel's (one alignment point per `target_voxel_m` of surface; a
// noisy shell several voxels thick repeats the same returns in its extra layers), but never
// more than the alignment points actually within the radius (a coarse scan leaves voxels
// empty). The error budget measured the found pose's error at 4.1-5.6 times the uncorrected
// 1-sigma over every family, noise and registration kind; the factor is 22 (4.7 in sigma) at
// the defaults on a dense scan.
double ResidualCorrelation(const Cloud& source, const AlignConfig& config) {
    if (config.smoothing_radius_m <= 0.0 || config.target_voxel_m <= 0.0 || source.empty()) {
        return 1.0;
    }
    const double disc = kPi * config.smoothing_radius_m * config.smoothing_radius_m;
    const double by_area = disc / (config.target_voxel_m * config.target_voxel_m);
    const cloud::KdTree tree(source);
    std::size_t neighbours = 0;
    for (const Eigen::Vector3f& p : source) {
        neighbours += tree.Radius(p, config.smoothing_radius_m).size();
    }
    const double by_count = static_cast<double>(neighbours) / static_cast<double>(source.size());
    return std::max(1.0, std::min(by_area, by_count));
}

// Figures at the final pose, fine distance: fitness, rmse and the pose covariance
// rmse^2 H^-1 over the left perturbation (rotation, translation) in the scan frame, widened by
// the residuals' correlation.
void Summarize(const Cloud& source, const Cloud& normals, const Target& target,
               const cloud::KdTree& tree, const AlignConfig& config, double min_cos, int threads,
               AlignResult& result) {
    const Pose& T = result.T_scan_container;
    const System sys = Linearize(source, normals, T, target, tree, config.max_correspondence_m,
                                 config.ransac_outlier_rejection_m, min_cos, threads);
    result.correspondences = sys.count;
    result.fitness = static_cast<double>(sys.count) / static_cast<double>(source.size());
    if (sys.count < 6) return;
    result.rmse_m = std::sqrt(sys.sq_sum / static_cast<double>(sys.count));
    result.covariance = ResidualCorrelation(source, config) * result.rmse_m * result.rmse_m *
                        (sys.H + 1e-9 * Matrix6d::Identity()).inverse();
    // Offset of the opening centre along its normal: d = n_c . (t + w x o).
    const Eigen::Vector3d o = T.translation();
    const Eigen::Vector3d nc = T.linear().col(2);
    Vector6d grad;
    grad << o.cross(nc), nc;
    result.z_sigma_m = std::sqrt(std::max(0.0, grad.dot(result.covariance * grad)));
}

ContentColumn::Side SideAt(const ContentColumn& column, bool inside, double edge) {
    return {inside, edge < column.wall_band_m, column.margin_m <= 0.0 || edge > column.margin_m};
}

constexpr uint8_t kDecided = 1, kInside = 2, kNearWall = 4, kBeyondMargin = 8;
// Cells enough for a fine raster over a bucket, coarser over a truck bed.
constexpr double kMaxColumnCells = 4096.0;

}  // namespace

ContentColumn::Side ContentColumn::SideOf(const Eigen::Vector2d& xy) const {
    return SideAt(*this, polygon.Contains(xy), polygon.DistanceToBoundary(xy));
}

ContentColumnIndex::ContentColumnIndex(ContentColumn column) : column_(std::move(column)) {
    if (column_.polygon.Vertices().size() < 3) return;
    // Beyond the band around the polygon's box no point is inside nor near a wall.
    const double reach = std::max({column_.wall_band_m, column_.margin_m, 0.0}) + 0.01;
    origin_ = column_.polygon.Min() - Eigen::Vector2d::Constant(reach);
    const Eigen::Vector2d extent =
        column_.polygon.Max() + Eigen::Vector2d::Constant(reach) - origin_;
    cell_m_ = std::max(0.01, std::sqrt(extent.prod() / kMaxColumnCells));
    cols_ = static_cast<int>(std::ceil(extent.x() / cell_m_));
    rows_ = static_cast<int>(std::ceil(extent.y() / cell_m_));
    cells_.assign(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_), 0);
    const double half_diagonal = 0.5 * std::sqrt(2.0) * cell_m_;
    const auto clear = [&](double edge, double threshold) {
        return std::abs(edge - threshold) > half_diagonal;
    };
    for (int r = 0; r < rows_; ++r) {
        for (int c = 0; c < cols_; ++c) {
            const Eigen::Vector2d centre = origin_ + cell_m_ * Eigen::Vector2d(c + 0.5, r + 0.5);
            const double edge = column_.polygon.DistanceToBoundary(centre);
            if (!clear(edge, 0.0) || !clear(edge, column_.wall_band_m) ||
                (column_.margin_m > 0.0 && !clear(edge, column_.margin_m))) {
                continue;
            }
            const ContentColumn::Side side =
                SideAt(column_, column_.polygon.Contains(centre), edge);
            cells_[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols_) +
                   static_cast<std::size_t>(c)] =
                static_cast<uint8_t>(kDecided | (side.inside ? kInside : 0) |
                                     (side.near_wall ? kNearWall : 0) |
                                     (side.beyond_margin ? kBeyondMargin : 0));
        }
    }
}

bool ContentColumnIndex::Holds(const Eigen::Vector3d& p) const {
    return column_.Holds(p, [this](const Eigen::Vector2d& xy) {
        const Eigen::Vector2d q = (xy - origin_) / cell_m_;
        if (!(q.x() >= 0.0 && q.y() >= 0.0 && q.x() < cols_ && q.y() < rows_)) {
            return ContentColumn::Side{};
        }
        const uint8_t cell =
            cells_[static_cast<std::size_t>(q.y()) * static_cast<std::size_t>(cols_) +
                   static_cast<std::size_t>(q.x())];
        if (!(cell & kDecided)) return column_.SideOf(xy);
        return ContentColumn::Side{(cell & kInside) != 0, (cell & kNearWall) != 0,
                                   (cell & kBeyondMargin) != 0};
    });
}

AlignResult Align(const Cloud& source, const Cloud& normals, const Cloud& scan,
                  const Pose& initial_T_scan_container, const AlignConfig& config,
                  const ContentColumn* column, const StopToken& stop) {
    AlignResult result;
    result.T_scan_container = initial_T_scan_container;
    if (source.empty()) return result;
    const double min_cos = std::cos(config.max_normal_angle_deg * 3.14159265358979 / 180.0);
    const int threads = config.num_threads > 0 ? config.num_threads : omp_get_max_threads();
    std::vector<double> stages;
    if (config.coarse_max_correspondence_m > config.max_correspondence_m) {
        stages.push_back(config.coarse_max_correspondence_m);
    }
    stages.push_back(config.max_correspondence_m);
    Pose& T = result.T_scan_container;
    Target target;
    for (std::size_t s = 0; s < stages.size(); ++s) {
        // Each stage crops the scan at the pose the last one found.
        const bool last = s + 1 == stages.size();
        ContentColumn band;
        if (column != nullptr) {
            band = *column;
            band.margin_m = last ? config.fine_column_margin_m : config.coarse_column_margin_m;
        }
        target = PrepareTarget(source, scan, T, config, column != nullptr ? &band : nullptr,
                               config.target_voxel_m, stop);
        result.target_points = target.points.size();
        if (target.points.empty() || stop.StopRequested()) return result;
        const cloud::KdTree tree(target.points);
        const bool fine = s + 1 == stages.size();
        bool stage_converged = false;
        std::vector<Pose> history;
        std::vector<double> costs;
        while (result.iterations < config.max_iterations && !stage_converged) {
            if (stop.StopRequested()) return result;
            const System sys = Linearize(source, normals, T, target, tree, stages[s],
                                         config.ransac_outlier_rejection_m, min_cos, threads);
            if (sys.count < 6) break;
            // Converged on the cost: noisy correspondences make the last steps cycle, but the
            // mean squared residual then stops falling.
            costs.push_back(sys.sq_sum / static_cast<double>(sys.count));
            if (CostSettled(costs, config)) {
                stage_converged = true;
                break;
            }
            const Matrix6d H = sys.H + 1e-9 * Matrix6d::Identity();
            const Vector6d xi = H.ldlt().solve(-sys.g);
            T = Exp(xi) * T;
            ++result.iterations;
            history.push_back(T);
            stage_converged = std::max(xi.head<3>().squaredNorm(), xi.tail<3>().squaredNorm()) <
                                  config.transformation_epsilon ||
                              Settled(history, config);
        }
        if (fine) result.converged = stage_converged;
        if (fine) Summarize(source, normals, target, tree, config, min_cos, threads, result);
    }
    return result;
}

absl::Status CheckAlignment(const AlignResult& result, const AlignGate& gate) {
    const double rot_sigma_deg =
        std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                                    result.covariance.topLeftCorner<3, 3>())
                                    .eigenvalues()
                                    .maxCoeff())) *
        180.0 / 3.14159265358979;
    const double trans_sigma_m =
        std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(
                                    result.covariance.bottomRightCorner<3, 3>())
                                    .eigenvalues()
                                    .maxCoeff()));
    const bool bad = result.correspondences < gate.min_correspondences ||
                     result.fitness < gate.min_fitness || result.rmse_m > gate.max_rmse_m ||
                     trans_sigma_m > gate.max_translation_sigma_m ||
                     rot_sigma_deg > gate.max_rotation_sigma_deg ||
                     (gate.require_converged && !result.converged);
    if (!bad) return absl::OkStatus();
    return absl::FailedPreconditionError(absl::StrFormat(
        "alignment rejected: %d matched points (minimum %d), fitness %.3f (minimum %.3f), rmse "
        "%.4f m (maximum %.4f m), pose 1-sigma %.4f m (maximum %.4f m) and %.2f deg (maximum "
        "%.2f deg), %s after %d iterations; is the container's outside visible and near its "
        "registered pose?",
        result.correspondences, gate.min_correspondences, result.fitness, gate.min_fitness,
        result.rmse_m, gate.max_rmse_m, trans_sigma_m, gate.max_translation_sigma_m, rot_sigma_deg,
        gate.max_rotation_sigma_deg, result.converged ? "converged" : "not converged",
        result.iterations));
}

}  // namespace soilvol::align
