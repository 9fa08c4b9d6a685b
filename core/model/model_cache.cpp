#include "core/model/model_cache.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/status_macros.hpp"

namespace soilvol::model {
namespace {

// Raster cells of half the radius; coarser when the opening is large.
constexpr double kRasterPerRadius = 0.5;
constexpr double kMaxRasterCells = 1 << 20;

}  // namespace

StructureIndex::StructureIndex(const ContainerModel& model)
    : points_(model.structure), tree_(points_), radius_m_(model.structure_radius_m) {
    if (radius_m_ <= 0.0 || points_.empty()) return;
    const Polygon2d& polygon = model.opening.polygon;
    origin_ = polygon.Min();
    const Eigen::Vector2d extent = (polygon.Max() - origin_).cwiseMax(1e-6);
    raster_m_ = std::max(kRasterPerRadius * radius_m_, std::sqrt(extent.prod() / kMaxRasterCells));
    cols_ = static_cast<int>(std::ceil(extent.x() / raster_m_));
    rows_ = static_cast<int>(std::ceil(extent.y() / raster_m_));
    lowest_near_.assign(static_cast<std::size_t>(cols_) * static_cast<std::size_t>(rows_),
                        std::numeric_limits<float>::infinity());
    // A point of a raster cell within the radius of a structure point puts that point within
    // radius + half diagonal of the cell's centre.
    const double reach = radius_m_ + raster_m_ * std::sqrt(0.5);
    const auto span = static_cast<int>(std::ceil(reach / raster_m_));
    for (const auto& s : points_) {
        const Eigen::Vector2d xy = s.head<2>().cast<double>();
        const Eigen::Vector2d f = (xy - origin_) / raster_m_;
        const int c0 = static_cast<int>(std::floor(f.x())),
                  r0 = static_cast<int>(std::floor(f.y()));
        for (int r = std::max(0, r0 - span); r <= std::min(rows_ - 1, r0 + span); ++r) {
            for (int c = std::max(0, c0 - span); c <= std::min(cols_ - 1, c0 + span); ++c) {
                const Eigen::Vector2d centre =
                    origin_ + raster_m_ * Eigen::Vector2d(c + 0.5, r + 0.5);
                if ((centre - xy).norm() > reach) continue;
                float& lowest =
                    lowest_near_[static_cast<std::size_t>(r) * static_cast<std::size_t>(cols_) +
                                 static_cast<std::size_t>(c)];
                lowest = std::min(lowest, s.z());
            }
        }
    }
}

bool StructureIndex::Near(const Eigen::Vector3f& p) const {
    if (points_.empty() || radius_m_ <= 0.0) return false;
    const Eigen::Vector2d f = (p.head<2>().cast<double>() - origin_) / raster_m_;
    if (f.x() >= 0.0 && f.y() >= 0.0 && f.x() < cols_ && f.y() < rows_) {
        const float lowest =
            lowest_near_[static_cast<std::size_t>(f.y()) * static_cast<std::size_t>(cols_) +
                         static_cast<std::size_t>(f.x())];
        if (static_cast<double>(p.z()) < static_cast<double>(lowest) - radius_m_) return false;
    }
    return tree_.AnyWithin(p, radius_m_);
}

const StructureIndex& ModelCache::Structure(const ContainerModel& model) {
    const std::lock_guard<std::mutex> lock(mu_);
    if (!structure_) structure_ = std::make_unique<StructureIndex>(model);
    return *structure_;
}

double ModelCache::EmptyMinZ(const ContainerModel& model) {
    const std::lock_guard<std::mutex> lock(mu_);
    if (!have_min_z_) {
        min_z_ = volume::EmptyMinZ(model.cavity);
        have_min_z_ = true;
    }
    return min_z_;
}

absl::StatusOr<std::shared_ptr<const volume::EmptySurface>> ModelCache::EmptySurface(
    const ContainerModel& model, const volume::Grid& grid, const volume::HeightmapConfig& config,
    const StopToken& stop) {
    {
        const std::lock_guard<std::mutex> lock(mu_);
        for (auto it = surfaces_.begin(); it != surfaces_.end(); ++it) {
            if (it->cell_m == grid.cell_m && it->config == config.surface) {
                surfaces_.splice(surfaces_.begin(), surfaces_, it);
                return surfaces_.front().surface;
            }
        }
    }
    // Computed outside the lock: calls on other grids do not wait; two first calls on one grid
    // both compute it, and the second result is dropped.
    SOILVOL_ASSIGN_OR_RETURN(volume::EmptySurface computed,
                             ModelEmptySurface(model, grid, config, stop));
    auto surface = std::make_shared<const volume::EmptySurface>(std::move(computed));
    const std::lock_guard<std::mutex> lock(mu_);
    for (const SurfaceEntry& e : surfaces_) {
        if (e.cell_m == grid.cell_m && e.config == config.surface) return e.surface;
    }
    surfaces_.push_front({grid.cell_m, config.surface, surface});
    if (surfaces_.size() > kMaxSurfaces) surfaces_.pop_back();
    return surface;
}

}  // namespace soilvol::model
