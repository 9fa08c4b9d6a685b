#pragma once

#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "core/cloud/kd_tree.hpp"
#include "core/common/types.hpp"
#include "core/model/container_model.hpp"
#include "core/volume/heightmap_volume.hpp"

namespace soilvol::model {

/// The container's structure as RemoveStructure queries it: a k-d tree over its own copy of the
/// points, and a raster over the opening's bounding box holding, per raster cell, the lowest
/// structure point within the radius (plus the cell's half diagonal) of it. A point lower than
/// that by the radius has no structure within the radius and needs no search.
class StructureIndex {
  public:
    explicit StructureIndex(const ContainerModel& model);
    StructureIndex(const StructureIndex&) = delete;
    StructureIndex& operator=(const StructureIndex&) = delete;

    /// Whether `p` (container frame) lies within the structure radius of the structure.
    bool Near(const Eigen::Vector3f& p) const;

  private:
    Cloud points_;
    cloud::KdTree tree_;
    double radius_m_ = 0.0;
    Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
    double raster_m_ = 1.0;
    int cols_ = 0, rows_ = 0;
    std::vector<float> lowest_near_;  // +inf where no structure point comes near
};

/// What estimates derive from a model and would otherwise rebuild on every call: the structure
/// index, the lowest inside height, and the empty surface for the last few grids. Built lazily,
/// thread-safe, shared by the copies of one model; a model that changes gets a new one
/// (FinishSurface), so an entry never outlives the data it came from.
class ModelCache {
  public:
    /// Empty surfaces kept, one per cell size and surface configuration (least recently used
    /// goes first).
    static constexpr std::size_t kMaxSurfaces = 4;

    const StructureIndex& Structure(const ContainerModel& model);
    double EmptyMinZ(const ContainerModel& model);
    /// A surface cut short by `stop` is not kept: the call returns the stop's status.
    absl::StatusOr<std::shared_ptr<const volume::EmptySurface>> EmptySurface(
        const ContainerModel& model, const volume::Grid& grid,
        const volume::HeightmapConfig& config, const StopToken& stop = {});

  private:
    struct SurfaceEntry {
        double cell_m;
        volume::SurfaceConfig config;
        std::shared_ptr<const volume::EmptySurface> surface;
    };
    std::mutex mu_;
    std::unique_ptr<StructureIndex> structure_;
    bool have_min_z_ = false;
    double min_z_ = 0.0;
    std::list<SurfaceEntry> surfaces_;  // most recently used first
};

}  // namespace soilvol::model
