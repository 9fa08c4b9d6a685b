#include "core/cloud/voxel_grid.hpp"

#include <algorithm>
#include <cmath>

namespace soilvol::cloud {
namespace {

constexpr int kMaxBits = 21;
constexpr int kMaxVoxels = (1 << kMaxBits) - 1;
constexpr int kRadixBits = 11;

int BitsFor(int count) {
    int bits = 0;
    while ((1 << bits) < count) ++bits;
    return bits;
}

// LSD radix sort of (key, index) pairs on the low `bits` bits of the key: stable, a histogram
// and a scatter per 11-bit digit.
void RadixSort(std::vector<std::pair<uint64_t, uint32_t>>& keyed, int bits) {
    std::vector<std::pair<uint64_t, uint32_t>> other(keyed.size());
    std::vector<std::size_t> count(std::size_t{1} << kRadixBits);
    for (int shift = 0; shift < bits; shift += kRadixBits) {
        std::fill(count.begin(), count.end(), 0);
        const uint64_t mask = (uint64_t{1} << kRadixBits) - 1;
        for (const auto& k : keyed) ++count[(k.first >> shift) & mask];
        std::size_t sum = 0;
        for (std::size_t& c : count) {
            const std::size_t n = c;
            c = sum;
            sum += n;
        }
        for (const auto& k : keyed) other[count[(k.first >> shift) & mask]++] = k;
        keyed.swap(other);
    }
}

}  // namespace

VoxelGrid::VoxelGrid(const Cloud& points, double voxel_size_m)
    : voxel_size_m_(voxel_size_m), origin_(Eigen::Vector3d::Zero()) {
    if (points.empty()) {
        starts_.push_back(0);
        return;
    }
    Eigen::Vector3f lo = points.front(), hi = points.front();
    for (const auto& p : points) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
    }
    origin_ = lo.cast<double>();
    for (int axis = 0; axis < 3; ++axis) {
        const double span = (static_cast<double>(hi[axis]) - origin_[axis]) / voxel_size_m_;
        dims_[axis] = static_cast<int>(std::min(std::floor(span), double{kMaxVoxels - 1})) + 1;
    }
    y_bits_ = BitsFor(dims_.y());
    z_bits_ = BitsFor(dims_.z());
    const int bits = BitsFor(dims_.x()) + y_bits_ + z_bits_;
    std::vector<std::pair<uint64_t, uint32_t>> keyed(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
        keyed[i] = {Pack(CoordOf(points[i]).cwiseMax(0).cwiseMin(dims_ - Eigen::Vector3i::Ones())),
                    static_cast<uint32_t>(i)};
    }
    RadixSort(keyed, bits);
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

uint64_t VoxelGrid::Pack(const Eigen::Vector3i& c) const {
    return (static_cast<uint64_t>(c.x()) << (y_bits_ + z_bits_)) |
           (static_cast<uint64_t>(c.y()) << z_bits_) | static_cast<uint64_t>(c.z());
}

bool VoxelGrid::InRange(const Eigen::Vector3i& c) const {
    return (c.array() >= 0).all() && (c.array() < dims_.array()).all();
}

Eigen::Vector3i VoxelGrid::Coord(std::size_t v) const {
    const uint64_t key = keys_[v];
    const uint64_t y_mask = (uint64_t{1} << y_bits_) - 1;
    const uint64_t z_mask = (uint64_t{1} << z_bits_) - 1;
    return {static_cast<int>(key >> (y_bits_ + z_bits_)),
            static_cast<int>((key >> z_bits_) & y_mask), static_cast<int>(key & z_mask)};
}

Eigen::Vector3i VoxelGrid::CoordOf(const Eigen::Vector3f& p) const {
    const Eigen::Vector3d q = (p.cast<double>() - origin_) / voxel_size_m_;
    // Far outside the grid is as good as just outside it; int stays in range.
    constexpr double kLimit = double{1 << 30};
    return {static_cast<int>(std::clamp(std::floor(q.x()), -kLimit, kLimit)),
            static_cast<int>(std::clamp(std::floor(q.y()), -kLimit, kLimit)),
            static_cast<int>(std::clamp(std::floor(q.z()), -kLimit, kLimit))};
}

int64_t VoxelGrid::Find(const Eigen::Vector3i& c) const {
    if (!InRange(c)) return -1;
    const uint64_t key = Pack(c);
    const auto it = std::lower_bound(keys_.begin(), keys_.end(), key);
    if (it == keys_.end() || *it != key) return -1;
    return it - keys_.begin();
}

std::pair<std::size_t, std::size_t> VoxelGrid::ColumnRange(const Eigen::Vector3i& c,
                                                           int count) const {
    const int z0 = std::max(c.z(), 0);
    const int z1 = std::min(c.z() + count - 1, dims_.z() - 1);
    if (c.x() < 0 || c.y() < 0 || c.x() >= dims_.x() || c.y() >= dims_.y() || z0 > z1) {
        return {0, 0};
    }
    const uint64_t lo = Pack({c.x(), c.y(), z0});
    const uint64_t hi = Pack({c.x(), c.y(), z1});
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

VoxelCentroids CentroidsOf(const Cloud& points, double voxel_size_m) {
    VoxelCentroids out;
    if (points.empty()) return out;
    const VoxelGrid grid(points, voxel_size_m);
    out.points.resize(grid.NumVoxels());
    out.counts.resize(grid.NumVoxels());
    out.voxel_of.resize(points.size());
    for (std::size_t v = 0; v < grid.NumVoxels(); ++v) {
        const auto [begin, end] = grid.Range(v);
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (std::size_t i = begin; i < end; ++i) {
            sum += points[grid.Order()[i]].cast<double>();
            out.voxel_of[grid.Order()[i]] = static_cast<uint32_t>(v);
        }
        out.points[v] = (sum / static_cast<double>(end - begin)).cast<float>();
        out.counts[v] = static_cast<float>(end - begin);
    }
    return out;
}

Cloud VoxelDownsample(const Cloud& points, double voxel_size_m) {
    if (voxel_size_m <= 0.0) return points;
    return CentroidsOf(points, voxel_size_m).points;
}

}  // namespace soilvol::cloud
