#include "core/model/thin_shell.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "core/common/statistics.hpp"

namespace soilvol::model {
namespace {

struct Edge {
    Eigen::Vector2d a, along, inward;
    double length = 0.0;
};

std::vector<Edge> EdgesOf(const Polygon2d& opening) {
    const auto& v = opening.Vertices();  // counter-clockwise: the inside is to the left
    std::vector<Edge> edges;
    for (std::size_t i = 0; i < v.size(); ++i) {
        Edge e;
        e.a = v[i];
        const Eigen::Vector2d d = v[(i + 1) % v.size()] - v[i];
        e.length = d.norm();
        e.along = d / std::max(e.length, 1e-12);
        e.inward = Eigen::Vector2d(-e.along.y(), e.along.x());
        edges.push_back(e);
    }
    return edges;
}

// The edge a point lies nearest to (within its length), with its inward distance.
int NearestEdge(const std::vector<Edge>& edges, const Eigen::Vector2d& xy, double* inward) {
    int best = -1;
    double best_abs = 1e300;
    for (std::size_t i = 0; i < edges.size(); ++i) {
        const Edge& e = edges[i];
        const double s = e.along.dot(xy - e.a);
        if (s < 0.0 || s > e.length) continue;
        const double d = e.inward.dot(xy - e.a);
        if (std::abs(d) < best_abs) {
            best_abs = std::abs(d);
            best = static_cast<int>(i);
            *inward = d;
        }
    }
    return best;
}

// Theil-Sen line d = a + b z (the median of the pairwise slopes, then of the intercepts): a
// lip or flange's few depth bins do not move it. Its intercept at the opening plane, and that
// intercept's 1-sigma from the scatter of the bins about the line.
bool InterceptAtRim(const std::vector<Eigen::Vector2d>& zd, double* intercept, double* sigma) {
    std::vector<double> slopes;
    for (std::size_t i = 0; i < zd.size(); ++i) {
        for (std::size_t j = i + 1; j < zd.size(); ++j) {
            const double dz = zd[j].x() - zd[i].x();
            if (std::abs(dz) > 1e-9) slopes.push_back((zd[j].y() - zd[i].y()) / dz);
        }
    }
    if (slopes.empty()) return false;
    const double b = Median(std::move(slopes));
    std::vector<double> a;
    for (const Eigen::Vector2d& p : zd) a.push_back(p.y() - b * p.x());
    *intercept = Median(a);
    *sigma = RobustSigma(a, *intercept) / std::sqrt(static_cast<double>(a.size()));
    return true;
}

}  // namespace

std::vector<WallPrior> InnerFaceFromOutside(const Cloud& outside, const Eigen::Vector3d& sensor,
                                            const Polygon2d& opening,
                                            const ThinShellConfig& config) {
    const std::vector<Edge> edges = EdgesOf(opening);
    // Each wall's outer-face returns: within reach of its edge, below the rim.
    std::vector<std::vector<Eigen::Vector2d>> faces(edges.size());  // (z, inward offset)
    for (const Eigen::Vector3f& p : outside) {
        const double z = static_cast<double>(p.z());
        if (z > -config.top_band_m) continue;
        double d = 0.0;
        const Eigen::Vector2d xy = p.head<2>().cast<double>();
        const int e = NearestEdge(edges, xy, &d);
        if (e < 0 || d < -config.reach_m) continue;
        const Edge& edge = edges[static_cast<std::size_t>(e)];
        if (edge.inward.dot(sensor.head<2>() - edge.a) >= 0.0) continue;  // seen from inside
        faces[static_cast<std::size_t>(e)].emplace_back(z, d);
    }
    std::vector<WallPrior> walls;
    for (std::size_t e = 0; e < edges.size(); ++e) {
        // The wall's profile: the outer face's median offset at each depth, over the whole
        // edge, so that noise does not scatter it.
        std::map<int, std::vector<double>> by_depth;
        for (const Eigen::Vector2d& f : faces[e]) {
            by_depth[static_cast<int>(std::floor(f.x() / config.bin_m))].push_back(f.y());
        }
        WallPrior wall;
        wall.edge = static_cast<int>(e);
        std::vector<Eigen::Vector2d> fit;
        double lean = -1.0;
        for (auto it = by_depth.rbegin(); it != by_depth.rend(); ++it) {  // from the rim down
            if (it->second.size() < config.min_bin_points) continue;
            const double z = (it->first + 0.5) * config.bin_m;
            wall.support += it->second.size();
            wall.profile.emplace_back(z, Median(std::move(it->second)));
            lean = std::max(lean, wall.profile.back().y());
            if (z >= -config.fit_depth_m) fit.push_back(wall.profile.back());
        }
        // Only a wall whose outside the view saw lean over the opening gets a prior: one that
        // does not hides nothing the empty surface's bounds do not already hold. Its thickness:
        // the profile's offset from the edge, followed up to the rim (below a lip or flange,
        // which stands out further).
        double intercept = 0.0;
        if (lean < config.min_lean_m || fit.size() < 4 || wall.support < config.min_points ||
            !InterceptAtRim(fit, &intercept, &wall.thickness_sigma_m)) {
            continue;
        }
        wall.thickness_m = -intercept;
        wall.thickness_sigma_m = std::max(wall.thickness_sigma_m, config.min_thickness_sigma_m);
        if (wall.thickness_m < config.min_thickness_m || wall.thickness_m > config.max_thickness_m)
            continue;
        for (Eigen::Vector2d& p : wall.profile) p.y() += wall.thickness_m;
        walls.push_back(std::move(wall));
    }
    return walls;
}

double PriorHeight(const std::vector<WallPrior>& walls, const Polygon2d& opening,
                   const Eigen::Vector2d& xy) {
    const std::vector<Edge> edges = EdgesOf(opening);
    double best = std::numeric_limits<double>::quiet_NaN();
    for (const WallPrior& wall : walls) {
        if (wall.edge < 0 || static_cast<std::size_t>(wall.edge) >= edges.size()) continue;
        const Edge& e = edges[static_cast<std::size_t>(wall.edge)];
        const double s = e.along.dot(xy - e.a);
        const double d = e.inward.dot(xy - e.a);
        if (s < 0.0 || s > e.length || d < 0.0) continue;
        // Down the profile from the rim, where the inner face passes through the edge, to the
        // first depth at which it lies this far inside.
        Eigen::Vector2d above(0.0, 0.0);
        for (const Eigen::Vector2d& p : wall.profile) {
            if (p.y() >= d) {
                const double span = p.y() - above.y();
                const double f = span > 1e-9 ? (d - above.y()) / span : 1.0;
                const double z = above.x() + f * (p.x() - above.x());
                if (!(z <= best)) best = z;
                break;
            }
            above = p;
        }
    }
    return best;
}

void ApplyWallPriors(const std::vector<WallPrior>& walls, const Polygon2d& opening,
                     const volume::Grid& grid, volume::EmptySurface& empty) {
    if (walls.empty()) return;
    constexpr int kSub = 4;
    for (std::size_t k = 0; k < empty.map.height.size(); ++k) {
        // A wall an empty scan saw from inside needs no prior.
        if (grid.weight[k] <= 0.0 || std::isnan(empty.map.height[k]) || empty.map.support[k] > 0)
            continue;
        const Eigen::Vector2d lo =
            grid.Center(static_cast<int>(k)) - Eigen::Vector2d::Constant(0.5 * grid.cell_m);
        double sum = 0.0;
        int n = 0;
        bool raised = false;
        for (int i = 0; i < kSub; ++i) {
            for (int j = 0; j < kSub; ++j) {
                const Eigen::Vector2d xy =
                    lo + grid.cell_m * Eigen::Vector2d((i + 0.5) / kSub, (j + 0.5) / kSub);
                if (!opening.Contains(xy)) continue;
                const double wall = PriorHeight(walls, opening, xy);
                double z = empty.map.height[k];
                if (wall > z) z = wall, raised = true;
                sum += z;
                ++n;
            }
        }
        if (!raised || n == 0) continue;
        empty.observed_area_m2 += grid.weight[k];
        empty.map.support[k] = 1;
        empty.map.height[k] = sum / n;
        empty.unobserved_sigma_m[k] = 0.0;
    }
}

void MergeWalls(const std::vector<WallPrior>& add, std::vector<WallPrior>& walls) {
    for (const WallPrior& w : add) {
        const auto it = std::find_if(walls.begin(), walls.end(),
                                     [&](const WallPrior& o) { return o.edge == w.edge; });
        if (it == walls.end()) {
            walls.push_back(w);
        } else if (w.support > it->support) {
            *it = w;
        }
    }
}

}  // namespace soilvol::model
