#include "core/cloud/voxel_grid.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::cloud {
namespace {

constexpr int kBits = 21;
constexpr int64_t kOffset = int64_t{1} << (kBits - 1);
constexpr uint64_t kMask = (uint64_t{1} << kBits) - 1;

uint64_t Pack(const Eigen::Vector3i& c) {
    return (static_cast<uint64_t>(c.x() + kOffset) & kMask) << (2 * kBits) |
           (static_cast<uint64_t>(c.y() + kOffset) & kMask) << kBits |
           (static_cast<uint64_t>(c.z() + kOffset) & kMask);
}

Eigen::Vector3i Unpack(uint64_t key) {
    return {static_cast<int>(static_cast<int64_t>((key >> (2 * kBits)) & kMask) - kOffset),
            static_cast<int>(static_cast<int64_t>((key >> kBits) & kMask) - kOffset),
            static_cast<int>(static_cast<int64_t>(key & kMask) - kOffset)};
}

}  // namespace

VoxelGrid::VoxelGrid(const Cloud& points, double voxel_size_m)
    : points_(points), voxel_size_m_(voxel_size_m), origin_(Eigen::Vector3d::Zero()) {
    if (!points.empty()) {
        Eigen::Vector3f lo = points.front();
        for (const auto& p : points) lo = lo.cwiseMin(p);
        origin_ = lo.cast<double>();
    }
    // Coordinates are relative to the cloud's minimum, so 21 bits per axis cover 2^21 voxels.
    std::vector<std::pair<uint64_t, uint32_t>> keyed(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        keyed[i] = {Pack(CoordOf(points[i])), static_cast<uint32_t>(i)};
    }
    std::sort(keyed.begin(), keyed.end());
    order_.resize(keyed.size());
    starts_.reserve(keyed.size() / 2 + 2);
    for (std::size_t i = 0; i < keyed.size(); ++i) {
        if (i == 0 || keyed[i].first != keyed[i - 1].first) {
            keys_.push_back(keyed[i].first);
            starts_.push_back(i);
        }
        order_[i] = keyed[i].second;
    }
    starts_.push_back(keyed.size());
}

Eigen::Vector3i VoxelGrid::Coord(std::size_t v) const { return Unpack(keys_[v]); }

Eigen::Vector3i VoxelGrid::CoordOf(const Eigen::Vector3f& p) const {
    const Eigen::Vector3d q = (p.cast<double>() - origin_) / voxel_size_m_;
    const double limit = static_cast<double>(kOffset - 2);
    return {static_cast<int>(std::clamp(std::floor(q.x()), -limit, limit)),
            static_cast<int>(std::clamp(std::floor(q.y()), -limit, limit)),
            static_cast<int>(std::clamp(std::floor(q.z()), -limit, limit))};
}

int64_t VoxelGrid::Find(const Eigen::Vector3i& c) const {
    const uint64_t key = Pack(c);
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    if (it == keys_.end() || *it != key) return -1;
    return it - keys_.begin();
}

std::pair<std::size_t, std::size_t> VoxelGrid::ColumnRange(const Eigen::Vector3i& c,
                                                           int count) const {
    const uint64_t lo = Pack(c);
    const uint64_t hi = Pack(c + Eigen::Vector3i(0, 0, count - 1));
    const auto first = std::lower_bound(keys_.begin(), keys_.end(), lo);
    auto last = first;
    while (last != keys_.end() && *last <= hi) ++last;
    return {static_cast<std::size_t>(first - keys_.begin()),
            static_cast<std::size_t>(last - keys_.begin())};
}

void VoxelGrid::GatherBlock(const Eigen::Vector3i& c, int reach, std::vector<uint32_t>& out) const {
    out.clear();
    for (int dx = -reach; dx <= reach; ++dx) {
        for (int dy = -reach; dy <= reach; ++dy) {
            // The voxels along z are one contiguous run of the sorted grid.
            const auto [first, last] =
                ColumnRange(c + Eigen::Vector3i(dx, dy, -reach), 2 * reach + 1);
            if (first == last) continue;
            out.insert(out.end(), order_.begin() + static_cast<long>(starts_[first]),
                       order_.begin() + static_cast<long>(starts_[last]));
        }
    }
}

Cloud VoxelDownsample(const Cloud& points, double voxel_size_m) {
    if (voxel_size_m <= 0.0) return points;
    const VoxelGrid grid(points, voxel_size_m);
    Cloud out;
    out.reserve(grid.NumVoxels());
    for (std::size_t v = 0; v < grid.NumVoxels(); ++v) {
        const auto [begin, end] = grid.Range(v);
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::size_t i = begin; i < end; ++i) sum += points[grid.Order()[i]].cast<double>();
        out.push_back((sum / static_cast<double>(end - begin)).cast<float>());
    }
    return out;
}

}  // namespace soilvol::cloud
