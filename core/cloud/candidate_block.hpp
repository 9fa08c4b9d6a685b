#pragma once

#include <cstdint>
#include <vector>

#include "core/common/types.hpp"

namespace soilvol::cloud {

/// Sums over the points of a neighbourhood, relative to its query point: what a mean and a
/// covariance need.
struct Moments {
    int count = 0;                                    ///< points
    double weight = 0.0;                              ///< sum of their weights
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();    ///< of w (q - p)
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();  ///< of w (q - p)(q - p)'
};

/// The points of a voxel block (their indices into a cloud) with their coordinates relative to
/// an anchor, one array per axis, so that a query's loop over them vectorises: every point of
/// a voxel asks the same block, and the neighbourhood searches of the outlier filter and the
/// local surfaces spend their time here.
class CandidateBlock {
  public:
    /// Index list to fill (GatherBlock), then Load.
    std::vector<uint32_t>& indices() { return index_; }
    const std::vector<uint32_t>& index() const { return index_; }
    /// Loads the coordinates of `indices()` from `points`, relative to `anchor` (a point near
    /// the block's queries: float stays precise over a neighbourhood), with their `weights`
    /// (one per point of `points`; empty: each weighs 1).
    void Load(const Cloud& points, const Eigen::Vector3f& anchor,
              const std::vector<float>& weights = {});

    /// Weighted moments of the block's points within sqrt(`radius2`) of `p` (an absolute
    /// position).
    Moments Within(const Eigen::Vector3f& p, float radius2) const;
    /// Squared distances from `p` to every block point, in block order, into `out`.
    void SquaredDistances(const Eigen::Vector3f& p, std::vector<float>& out) const;

  private:
    std::vector<uint32_t> index_;
    std::vector<float> x_, y_, z_, w_;
    Eigen::Vector3f anchor_ = Eigen::Vector3f::Zero();
};

}  // namespace soilvol::cloud
