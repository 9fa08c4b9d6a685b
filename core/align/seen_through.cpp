#include "core/align/seen_through.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/cloud/kd_tree.hpp"
#include "core/common/statistics.hpp"

namespace soilvol::align {

SeenThrough SeenThroughShare(const Cloud& model_in_scan, const Cloud& scan, double noise_sigma_m,
                             const SeenThroughConfig& config) {
    SeenThrough out;
    Cloud directions;
    std::vector<float> ranges;
    const std::size_t stride = std::max<std::size_t>(
        1, (scan.size() + config.max_returns - 1) / std::max<std::size_t>(config.max_returns, 1));
    directions.reserve(scan.size() / stride + 1);
    ranges.reserve(scan.size() / stride + 1);
    for (std::size_t i = 0; i < scan.size(); i += stride) {
        const Eigen::Vector3f& p = scan[i];
        const float r = p.norm();
        if (!(r > 0.0f)) continue;
        directions.push_back(p / r);
        ranges.push_back(r);
    }
    if (directions.size() < 2) return out;
    const cloud::KdTree tree(directions);
    // Angular spacing: the median angle to the nearest other return (not a repeat of the
    // same direction), over a sample.
    constexpr std::size_t kNearest = 4;
    std::vector<float> gaps;
    const std::size_t step = std::max<std::size_t>(1, directions.size() / 500);
    for (std::size_t i = 0; i < directions.size(); i += step) {
        for (const auto& [j, d2] : tree.Nearest(directions[i], kNearest)) {
            if (j == i || !(d2 > 0.0f)) continue;
            if (d2 < 0.05f * 0.05f) gaps.push_back(std::sqrt(d2));
            break;
        }
    }
    if (gaps.empty()) return out;
    const double tolerance = config.spacings * Median(gaps);
    const double margin = std::max(config.min_margin_m, config.margin_sigmas * noise_sigma_m);
    for (const auto& p : model_in_scan) {
        const double r = static_cast<double>(p.norm());
        if (!(r > 0.0)) continue;
        const auto near = tree.Radius((p / static_cast<float>(r)), tolerance);
        if (near.empty()) continue;
        ++out.tested;
        float nearest_range = 1e30f;
        for (const auto& [j, d2] : near) nearest_range = std::min(nearest_range, ranges[j]);
        if (static_cast<double>(nearest_range) > r + margin) ++out.through;
    }
    return out;
}

}  // namespace soilvol::align
