#pragma once

#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "core/common/types.hpp"

namespace soilvol::cloud {

/// Exact nearest-neighbour queries over a cloud (nanoflann k-d tree). The cloud must outlive
/// the tree. Queries are thread-safe.
class KdTree {
  public:
    explicit KdTree(const Cloud& points);
    ~KdTree();
    KdTree(const KdTree&) = delete;
    KdTree& operator=(const KdTree&) = delete;

    /// Index and squared distance [m^2] of the nearest point; {-1, inf} for an empty cloud.
    std::pair<int64_t, float> Nearest(const Eigen::Vector3f& query) const;
    /// The `k` nearest points (fewer in a smaller cloud) as (index, squared distance), nearest
    /// first.
    std::vector<std::pair<uint32_t, float>> Nearest(const Eigen::Vector3f& query,
                                                    std::size_t k) const;
    /// Whether any point lies within `radius_m` (inclusive); stops at the first it finds.
    bool AnyWithin(const Eigen::Vector3f& query, double radius_m) const;
    /// All points within `radius_m` as (index, squared distance), unsorted.
    std::vector<std::pair<uint32_t, float>> Radius(const Eigen::Vector3f& query,
                                                   double radius_m) const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace soilvol::cloud
