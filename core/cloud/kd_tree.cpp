#include "core/cloud/kd_tree.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>

namespace soilvol::cloud {
namespace {

struct CloudAdaptor {
    const Cloud& points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    float kdtree_get_pt(std::size_t i, std::size_t d) const {
        return points[i][static_cast<int>(d)];
    }
    template <class Box>
    bool kdtree_get_bbox(Box&) const {
        return false;
    }
};

// A result set that takes the first point within its bound and ends the search.
class FirstWithin {
  public:
    explicit FirstWithin(float bound2) : bound2_(bound2) {}
    void init() {}
    std::size_t size() const { return found_ ? 1 : 0; }
    bool full() const { return true; }
    bool addPoint(float dist2, uint32_t) {
        found_ = dist2 < bound2_;
        return !found_;
    }
    float worstDist() const { return bound2_; }
    bool found() const { return found_; }

  private:
    float bound2_;
    bool found_ = false;
};

using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, CloudAdaptor>,
                                                  CloudAdaptor, 3, uint32_t>;

}  // namespace

struct KdTree::Impl {
    explicit Impl(const Cloud& points)
        : adaptor{points}, index(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
    CloudAdaptor adaptor;
    Index index;
};

KdTree::KdTree(const Cloud& points) : impl_(std::make_unique<Impl>(points)) {
    if (!points.empty()) impl_->index.buildIndex();
}

KdTree::~KdTree() = default;

std::pair<int64_t, float> KdTree::Nearest(const Eigen::Vector3f& query) const {
    if (impl_->adaptor.points.empty()) return {-1, std::numeric_limits<float>::infinity()};
    uint32_t index = 0;
    float dist2 = 0.0f;
    impl_->index.knnSearch(query.data(), 1, &index, &dist2);
    return {index, dist2};
}

std::vector<std::pair<uint32_t, float>> KdTree::Nearest(const Eigen::Vector3f& query,
                                                        std::size_t k) const {
    k = std::min(k, impl_->adaptor.points.size());
    std::vector<uint32_t> index(k);
    std::vector<float> dist2(k);
    if (k > 0) k = impl_->index.knnSearch(query.data(), k, index.data(), dist2.data());
    std::vector<std::pair<uint32_t, float>> out(k);
    for (std::size_t i = 0; i < k; ++i) out[i] = {index[i], dist2[i]};
    return out;
}

bool KdTree::AnyWithin(const Eigen::Vector3f& query, double radius_m) const {
    if (impl_->adaptor.points.empty() || !(radius_m >= 0.0)) return false;
    // nanoflann keeps points strictly nearer than the bound: the next float up includes r^2.
    FirstWithin result(std::nextafter(static_cast<float>(radius_m * radius_m),
                                      std::numeric_limits<float>::infinity()));
    impl_->index.findNeighbors(result, query.data(), nanoflann::SearchParams());
    return result.found();
}

std::vector<std::pair<uint32_t, float>> KdTree::Radius(const Eigen::Vector3f& query,
                                                       double radius_m) const {
    std::vector<std::pair<uint32_t, float>> out;
    if (impl_->adaptor.points.empty()) return out;
    nanoflann::SearchParams params;
    params.sorted = false;
    impl_->index.radiusSearch(query.data(), static_cast<float>(radius_m * radius_m), out, params);
    return out;
}

}  // namespace soilvol::cloud
