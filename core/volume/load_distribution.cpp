#include "core/volume/load_distribution.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

namespace soilvol::volume {

LoadDistribution DistributionOf(const VolumeResult& result) {
    LoadDistribution out;
    const Grid& grid = result.grid;
    double total = 0.0;
    double positive_x = 0.0;
    double positive_y = 0.0;
    Eigen::Vector2d moment = Eigen::Vector2d::Zero();
    Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector2d hi = -lo;
    for (int k = 0; k < grid.NumCells(); ++k) {
        const double weight = k < static_cast<int>(grid.weight.size()) ? grid.weight[k] : 0.0;
        if (weight <= 0.0) continue;
        const Eigen::Vector2d at = grid.anchor.empty() ? grid.Center(k) : grid.anchor[k];
        lo = lo.cwiseMin(at);
        hi = hi.cwiseMax(at);
        const double h = result.soil_height_m[k];
        if (!std::isfinite(h) || h <= 0.0) continue;
        const double v = h * weight;
        total += v;
        moment += v * at;
        if (at.x() > 0.0) positive_x += v;
        if (at.y() > 0.0) positive_y += v;
    }
    out.volume_m3 = total;
    if (total <= 0.0) return out;
    out.centre_m = moment / total;
    out.positive_x_share = positive_x / total;
    out.positive_y_share = positive_y / total;
    // The half-extent of the occupied cells along the centre's direction, from the origin.
    const Eigen::Vector2d half = (hi - lo).cwiseAbs() / 2.0;
    if (half.x() > 0.0 && half.y() > 0.0) {
        const Eigen::Vector2d scaled = out.centre_m.cwiseQuotient(half);
        out.asymmetry = std::min(1.0, scaled.cwiseAbs().maxCoeff());
    }
    return out;
}

std::string PackedHeights(const VolumeResult& result) {
    const int cells = result.grid.NumCells();
    std::string out(static_cast<std::size_t>(cells) * sizeof(float), '\0');
    for (int k = 0; k < cells; ++k) {
        const bool observed = k < static_cast<int>(result.state.size()) &&
                              result.state[k] == CellState::kMeasured &&
                              std::isfinite(result.soil_height_m[k]);
        const float h = observed ? static_cast<float>(result.soil_height_m[k])
                                 : std::numeric_limits<float>::quiet_NaN();
        std::uint32_t bits = 0;
        std::memcpy(&bits, &h, sizeof bits);
        for (int b = 0; b < 4; ++b) {
            out[static_cast<std::size_t>(k) * 4 + b] = static_cast<char>((bits >> (8 * b)) & 0xff);
        }
    }
    return out;
}

}  // namespace soilvol::volume
