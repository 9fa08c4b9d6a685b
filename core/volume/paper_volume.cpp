#include "core/volume/paper_volume.hpp"

#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_plane.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"

namespace soilvol::volume {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct CellPlane {
    Eigen::Vector4d coefficients = Eigen::Vector4d::Zero();  // n . p + d = 0, |n| = 1, n.z >= 0
    Eigen::Vector3d median = Eigen::Vector3d::Zero();        // median point on the plane
    bool fitted = false;
};

Eigen::Vector3d ComponentMedian(std::vector<Eigen::Vector3d> points) {
    Eigen::Vector3d m;
    for (int axis = 0; axis < 3; ++axis) {
        std::vector<double> v;
        v.reserve(points.size());
        for (const auto& p : points) v.push_back(p(axis));
        const auto mid = v.begin() + static_cast<long>(v.size() / 2);
        std::nth_element(v.begin(), mid, v.end());
        m(axis) = *mid;
    }
    return m;
}

Eigen::Vector3d ProjectOntoPlane(const Eigen::Vector4d& plane, const Eigen::Vector3d& p) {
    return p - (plane.head<3>().dot(p) + plane(3)) * plane.head<3>();
}

// Sec. 3.4: RANSAC plane of one cell's points and the median of its inliers on that plane.
std::optional<CellPlane> FitCell(const Cloud& points, const std::vector<int>& members,
                                 const PaperConfig& config) {
    if (static_cast<int>(members.size()) < std::max(3, config.min_points)) return std::nullopt;
    pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
    cloud->reserve(members.size());
    for (const int i : members) {
        const auto& p = points[static_cast<std::size_t>(i)];
        cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
    }
    const pcl::SampleConsensusModelPlane<pcl::PointXYZ>::Ptr model(
        new pcl::SampleConsensusModelPlane<pcl::PointXYZ>(cloud, /*random=*/false));
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, config.ransac_threshold_m);
    ransac.setMaxIterations(config.ransac_iterations);
    if (!ransac.computeModel()) return std::nullopt;
    std::vector<int> inliers;
    ransac.getInliers(inliers);
    Eigen::VectorXf coefficients;
    ransac.getModelCoefficients(coefficients);
    if (inliers.size() < 3 || coefficients.size() != 4) return std::nullopt;
    CellPlane plane;
    plane.coefficients = coefficients.cast<double>();
    plane.coefficients /= plane.coefficients.head<3>().norm();
    if (plane.coefficients(2) < 0.0) plane.coefficients = -plane.coefficients;
    std::vector<Eigen::Vector3d> projected;
    for (const int i : inliers) {
        projected.push_back(ProjectOntoPlane(
            plane.coefficients,
            (*cloud)[static_cast<std::size_t>(i)].getVector3fMap().cast<double>()));
    }
    plane.median = ComponentMedian(std::move(projected));
    plane.fitted = true;
    return plane;
}

// Sec. 3.4: a hole takes the mean coefficients of the nearest ring of cells that have planes;
// its median point is where the vertical through the cell centre meets that plane.
void FillHoles(const Grid& grid, std::vector<CellPlane>& planes, const StopToken& stop) {
    const std::vector<CellPlane> fitted = planes;
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        CellPlane& hole = planes[static_cast<std::size_t>(cell)];
        if (hole.fitted) continue;
        if (stop.StopRequested()) return;
        const int col = cell % grid.cols, row = cell / grid.cols;
        Eigen::Vector4d sum = Eigen::Vector4d::Zero();
        int n = 0;
        for (int ring = 1; n == 0 && ring <= std::max(grid.cols, grid.rows); ++ring) {
            for (int r = row - ring; r <= row + ring; ++r) {
                for (int c = col - ring; c <= col + ring; ++c) {
                    if (std::max(std::abs(r - row), std::abs(c - col)) != ring) continue;
                    if (r < 0 || c < 0 || r >= grid.rows || c >= grid.cols) continue;
                    const CellPlane& other = fitted[static_cast<std::size_t>(r * grid.cols + c)];
                    if (!other.fitted) continue;
                    sum += other.coefficients;
                    ++n;
                }
            }
        }
        if (n == 0) continue;
        hole.coefficients = sum / n;
        hole.coefficients /= hole.coefficients.head<3>().norm();
        const Eigen::Vector2d centre = grid.Center(cell);
        const Eigen::Vector4d& p = hole.coefficients;
        const double z =
            std::abs(p(2)) > 1e-6 ? -(p(0) * centre.x() + p(1) * centre.y() + p(3)) / p(2) : 0.0;
        hole.median = Eigen::Vector3d(centre.x(), centre.y(), z);
    }
}

absl::StatusOr<std::vector<CellPlane>> FitGrid(const Grid& grid, const Cloud& points,
                                               const PaperConfig& config, const char* what,
                                               const StopToken& stop) {
    const CellBins bins = BinPoints(grid, points);
    std::vector<CellPlane> planes(static_cast<std::size_t>(grid.NumCells()));
    int fitted = 0;
    for (int cell = 0; cell < grid.NumCells(); ++cell) {
        if (stop.StopRequested()) break;
        const auto k = static_cast<std::size_t>(cell);
        const std::vector<int> members(bins.index.begin() + bins.start[k],
                                       bins.index.begin() + bins.start[k + 1]);
        if (auto plane = FitCell(points, members, config)) {
            planes[k] = *plane;
            ++fitted;
        }
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("plane fits of the ", what)));
    if (fitted == 0) {
        return absl::FailedPreconditionError(
            absl::StrCat("paper method: no cell of the ", what, " has a plane"));
    }
    FillHoles(grid, planes, stop);
    SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("hole filling of the ", what)));
    return planes;
}

}  // namespace

absl::StatusOr<VolumeResult> PaperVolume(const Cloud& empty_inside, const Cloud& scan_column,
                                         const Polygon2d& opening, const PaperConfig& config,
                                         const StopToken& stop) {
    VolumeResult result;
    Grid& grid = result.grid;
    grid.cell_m = config.cell_m;
    grid.origin = opening.Min();
    const Eigen::Vector2d shape = GridShape(opening, config.cell_m);
    grid.cols = static_cast<int>(shape.x());
    grid.rows = static_cast<int>(shape.y());
    grid.weight.assign(static_cast<std::size_t>(grid.NumCells()), config.cell_m * config.cell_m);
    auto model = FitGrid(grid, empty_inside, config, "model", stop);
    if (!model.ok()) return model.status();
    auto scan = FitGrid(grid, scan_column, config, "scan", stop);
    if (!scan.ok()) return scan.status();
    const auto num_cells = static_cast<std::size_t>(grid.NumCells());
    result.soil_height_m.assign(num_cells, kNaN);
    result.state.assign(num_cells, CellState::kMeasured);
    for (std::size_t k = 0; k < num_cells; ++k) {
        const CellPlane& m = (*model)[k];
        const CellPlane& s = (*scan)[k];
        // Sec. 3.4: Euclidean distance between the two median points, times the cell area.
        const double h = (s.median - m.median).norm();
        result.soil_height_m[k] = h;
        result.raw_volume_m3 += h * grid.weight[k];
        ++result.cells.total;
        if (s.fitted) {
            ++result.cells.measured;
        } else {
            result.state[k] = CellState::kInterpolated;
            ++result.cells.interpolated;
        }
        if (h > 0.0) ++result.cells.with_soil;
    }
    result.volume_m3 = result.raw_volume_m3;
    return result;
}

}  // namespace soilvol::volume
