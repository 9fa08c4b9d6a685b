#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/common/types.hpp"

namespace soilvol::cloud {

/// Points bucketed into cubic voxels of `voxel_size_m`, sorted by voxel so that each voxel is
/// one contiguous range of `Order()`. Lookups are by integer voxel coordinates, counted from
/// the cloud's lowest corner (each axis holds at most 2^21 voxels; farther points share the
/// last). Building costs a few linear passes (a radix sort on keys as wide as the extent).
class VoxelGrid {
  public:
    /// Buckets `points` (kept by reference; must outlive the grid). `voxel_size_m` > 0.
    VoxelGrid(const Cloud& points, double voxel_size_m);

    double VoxelSize() const { return voxel_size_m_; }
    /// Number of occupied voxels.
    std::size_t NumVoxels() const { return starts_.size() - 1; }
    /// Point indices of occupied voxel `v` as [begin, end) into Order().
    std::pair<std::size_t, std::size_t> Range(std::size_t v) const {
        return {starts_[v], starts_[v + 1]};
    }
    /// Point indices sorted by voxel.
    const std::vector<uint32_t>& Order() const { return order_; }
    /// Integer coordinates of occupied voxel `v`.
    Eigen::Vector3i Coord(std::size_t v) const;
    /// Occupied voxel at integer coordinates `c`, or -1.
    int64_t Find(const Eigen::Vector3i& c) const;
    /// Occupied voxels [first, last) among c, c + z, ..., c + (count - 1) z: one sorted run.
    std::pair<std::size_t, std::size_t> ColumnRange(const Eigen::Vector3i& c, int count) const;
    /// Indices of the points in the (2 reach + 1)^3 voxels around `c`, into `out` (cleared).
    void GatherBlock(const Eigen::Vector3i& c, int reach, std::vector<uint32_t>& out) const;
    /// Integer coordinates of the voxel holding `p`.
    Eigen::Vector3i CoordOf(const Eigen::Vector3f& p) const;

  private:
    // Key of in-range coordinates: x, y, z in bit fields just wide enough for the cloud's
    // extent, x most significant (each (x, y) column is one run of ascending keys).
    uint64_t Pack(const Eigen::Vector3i& c) const;
    bool InRange(const Eigen::Vector3i& c) const;

    double voxel_size_m_;
    Eigen::Vector3d origin_;
    Eigen::Vector3i dims_ = Eigen::Vector3i::Zero();  // voxels along each axis
    int y_bits_ = 0, z_bits_ = 0;
    std::vector<uint64_t> keys_;  // one per occupied voxel, ascending
    std::vector<std::size_t> starts_;
    std::vector<uint32_t> order_;
};

/// The centroid of each occupied voxel with the number of points it stands for, and the
/// centroid each input point went to. A mean over centroids weighted by their counts is the
/// mean over the points themselves: it does not change with the scan's density, where a mean
/// over centroids alone weighs a dense scan's sparse noise tails like its surface.
struct VoxelCentroids {
    Cloud points;
    std::vector<float> counts;
    std::vector<uint32_t> voxel_of;
};

/// Centroids of the voxels of `voxel_size_m` (> 0).
VoxelCentroids CentroidsOf(const Cloud& points, double voxel_size_m);

/// Centroid of the points in each occupied voxel of `voxel_size_m` (<= 0 returns a copy).
Cloud VoxelDownsample(const Cloud& points, double voxel_size_m);

}  // namespace soilvol::cloud
