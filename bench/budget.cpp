#include "bench/budget.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/stereo_trial.hpp"
#include "bench/trial.hpp"
#include "core/cloud/preprocess.hpp"
#include "core/common/angles.hpp"
#include "core/common/statistics.hpp"
#include "core/model/opening.hpp"
#include "core/pipeline/estimator.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/soil_surface.hpp"
#include "core/stereo/reconstructor.hpp"

namespace soilvol::bench {
namespace {

constexpr std::array<double, 6> kFillShares = {0.0, 0.25, 0.5, 0.75, 1.0, 1.3};

// One estimate's error [% of struck] split by stage; `refused` when the product gave no answer
// (its terms at the true pose are still measured).
struct Split {
    bool refused = false;
    double total = 0.0;  // the product's answer (clipped at 0) minus the truth
    double pose = 0.0, empty = 0.0, soil = 0.0, grid = 0.0;
    double sigma = 0.0;       // the product's 1-sigma
    double pose_sigma = 0.0;  // its part from the pose covariance
    double height_mm = 0.0, tilt_deg = 0.0;
    // At the true pose, the empty and scan surfaces' errors [% of struck] over the cells whose
    // true empty surface falls by more than a cell across it (walls), and over the rest.
    double empty_wall = 0.0, empty_flat = 0.0, scan_wall = 0.0, scan_flat = 0.0;
};

// A cell's true value: the mean of `f` (model frame) over 4 x 4 samples of the cell's part
// inside the opening (its anchor when none falls there), as a grid can hold a surface.
template <class F>
double CellMean(const volume::Grid& grid, const Polygon2d& opening, std::size_t k, const F& f) {
    constexpr int kSub = 4;
    const Eigen::Vector2d lo =
        grid.Center(static_cast<int>(k)) - Eigen::Vector2d::Constant(0.5 * grid.cell_m);
    double sum = 0.0;
    int n = 0;
    for (int i = 0; i < kSub; ++i) {
        for (int j = 0; j < kSub; ++j) {
            const Eigen::Vector2d xy =
                lo + grid.cell_m * Eigen::Vector2d((i + 0.5) / kSub, (j + 0.5) / kSub);
            if (!opening.Contains(xy)) continue;
            sum += f(xy);
            ++n;
        }
    }
    return n > 0 ? sum / n : f(grid.anchor[k]);
}

// The simulator's inner surface at (x, y) of the model frame.
double TrueEmptyAt(const sim::ContainerGeometry& geometry, const Pose& T_sim_model,
                   const Eigen::Vector2d& xy) {
    const Eigen::Vector3d p = T_sim_model * Eigen::Vector3d(xy.x(), xy.y(), 0.0);
    return geometry.InnerSurfaceZ(p.x(), p.y()) - p.z();
}

}  // namespace

double TrueEmptyCell(const volume::Grid& grid, const Polygon2d& opening, std::size_t k,
                     const sim::ContainerGeometry& geometry, const Pose& T_sim_model) {
    return CellMean(grid, opening, k, [&](const Eigen::Vector2d& xy) {
        return TrueEmptyAt(geometry, T_sim_model, xy);
    });
}

namespace {

// The exact empty surface on any grid of the model frame, cell means.
volume::EmptySide TrueEmpty(const sim::ContainerGeometry& geometry, const Polygon2d& opening,
                            const Pose& T_sim_model) {
    return {-geometry.depth_m,
            [&geometry, &opening, T_sim_model](const volume::Grid& grid)
                -> absl::StatusOr<std::shared_ptr<const volume::EmptySurface>> {
                auto out = std::make_shared<volume::EmptySurface>();
                const auto n = static_cast<std::size_t>(grid.NumCells());
                out->map.height.assign(n, std::nan(""));
                out->map.variance.assign(n, 0.0);
                out->map.support.assign(n, 0);
                out->map.observed.assign(n, 0.0);
                out->unobserved_sigma_m.assign(n, 0.0);
                for (std::size_t k = 0; k < n; ++k) {
                    if (grid.weight[k] <= 0.0) continue;
                    out->map.height[k] = TrueEmptyCell(grid, opening, k, geometry, T_sim_model);
                    out->map.support[k] = 1;
                    out->map.observed[k] = 1.0;
                    out->area_m2 += grid.weight[k];
                }
                out->observed_area_m2 = out->area_m2;
                out->map.noise_sigma_m = 1e-4;
                return std::shared_ptr<const volume::EmptySurface>(std::move(out));
            }};
}

// The true soil volume over a grid of the model frame, cell means.
double TrueOnGrid(const volume::Grid& grid, const Polygon2d& opening,
                  const sim::ContainerGeometry& geometry, const sim::SoilSurface& soil,
                  const Pose& T_sim_model) {
    if (soil.Empty()) return 0.0;
    double v = 0.0;
    for (std::size_t k = 0; k < grid.weight.size(); ++k) {
        if (grid.weight[k] <= 0.0) continue;
        v += grid.weight[k] * CellMean(grid, opening, k, [&](const Eigen::Vector2d& xy) {
                 const Eigen::Vector3d p = T_sim_model * Eigen::Vector3d(xy.x(), xy.y(), 0.0);
                 return std::max(0.0, soil.SurfaceZ(p.x(), p.y()) - p.z() -
                                          TrueEmptyAt(geometry, T_sim_model, xy));
             });
    }
    return v;
}

Split SplitError(const RegisteredModel& reg, const sim::ContainerGeometry& geometry,
                 const sim::SoilSurface& soil, const sim::Scene& scene,
                 const pipeline::EstimateConfig& config = {}) {
    const model::ContainerModel& model = *reg.model;
    const double pct = 100.0 / reg.true_struck_m3;
    Split out;
    const auto product = pipeline::EstimateVolume(model, scene.points, config);
    const Pose T_true = scene.T_scan_container * reg.sim_to_model;
    const cloud::PreprocessResult pre = cloud::Preprocess(scene.points, config.preprocess);
    const Cloud aligned = model::ToContainerFrame(pre.points, T_true);
    const auto at_pose = pipeline::IntegrateVolume(model, aligned, T_true, config);
    const auto with_empty =
        pipeline::IntegrateVolume(model, aligned, T_true, config,
                                  TrueEmpty(geometry, model.opening.polygon, reg.sim_to_model));
    if (!at_pose.ok() || !with_empty.ok()) {
        out.refused = true;
        return out;
    }
    const double on_grid =
        TrueOnGrid(with_empty->grid, model.opening.polygon, geometry, soil, reg.sim_to_model);
    {
        // Where the surfaces' errors lie: cells whose true empty surface falls by more than a
        // cell across them (walls), and the rest.
        const volume::Grid& g = at_pose->grid;
        const Polygon2d& opening = model.opening.polygon;
        for (std::size_t k = 0; k < g.weight.size(); ++k) {
            if (g.weight[k] <= 0.0) continue;
            double lo = 1e9, hi = -1e9;
            const double h = 0.5 * g.cell_m;
            for (const double dx : {-h, 0.0, h}) {
                for (const double dy : {-h, 0.0, h}) {
                    const double z = TrueEmptyAt(geometry, reg.sim_to_model,
                                                 g.anchor[k] + Eigen::Vector2d(dx, dy));
                    lo = std::min(lo, z), hi = std::max(hi, z);
                }
            }
            const bool wall = hi - lo > g.cell_m;
            const auto empty_at = [&](const Eigen::Vector2d& xy) {
                return TrueEmptyAt(geometry, reg.sim_to_model, xy);
            };
            const double e_true = CellMean(g, opening, k, empty_at);
            const double f_true = CellMean(g, opening, k, [&](const Eigen::Vector2d& xy) {
                const Eigen::Vector3d p = reg.sim_to_model * Eigen::Vector3d(xy.x(), xy.y(), 0.0);
                const double e = empty_at(xy);
                return soil.Empty() ? e : std::max(e, soil.SurfaceZ(p.x(), p.y()) - p.z());
            });
            const double f_est = at_pose->scan_surface_m[k];
            const double e_est = f_est - at_pose->soil_height_m[k];
            (wall ? out.empty_wall : out.empty_flat) += pct * g.weight[k] * (e_true - e_est);
            (wall ? out.scan_wall : out.scan_flat) += pct * g.weight[k] * (f_est - f_true);
        }
    }
    out.empty = pct * (at_pose->raw_volume_m3 - with_empty->raw_volume_m3);
    out.soil = pct * (with_empty->raw_volume_m3 - on_grid);
    out.grid = pct * (on_grid - scene.true_volume_m3);
    if (!product.ok()) {
        out.refused = true;
        return out;
    }
    out.pose = pct * (product->volume.raw_volume_m3 - at_pose->raw_volume_m3);
    out.total = pct * (product->volume_m3 - scene.true_volume_m3);
    out.sigma = pct * product->uncertainty_m3;
    out.pose_sigma = pct * product->pose_uncertainty_m3;
    const Pose delta = T_true.inverse() * product->alignment.T_scan_container;
    out.height_mm = 1000.0 * delta.translation().z();
    out.tilt_deg = std::acos(std::clamp(delta.linear()(2, 2), -1.0, 1.0)) * 180.0 / kPi;
    return out;
}

struct Row {
    std::vector<Split> splits;
    int refused = 0;
    std::vector<double> capacity_pct;
    int register_failures = 0;
};

double MeanAbsOf(const std::vector<Split>& s, double Split::*field) {
    double sum = 0.0;
    for (const Split& x : s) sum += std::abs(x.*field);
    return s.empty() ? 0.0 : sum / static_cast<double>(s.size());
}
double MeanOf(const std::vector<Split>& s, double Split::*field) {
    double sum = 0.0;
    for (const Split& x : s) sum += x.*field;
    return s.empty() ? 0.0 : sum / static_cast<double>(s.size());
}
double MaxAbsOf(const std::vector<Split>& s, double Split::*field) {
    double m = 0.0;
    for (const Split& x : s) m = std::max(m, std::abs(x.*field));
    return m;
}
double MeanAbs(const std::vector<double>& v) {
    double sum = 0.0;
    for (const double x : v) sum += std::abs(x);
    return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

std::string FormatRow(const std::string& label, const Row& row) {
    const std::vector<Split>& s = row.splits;
    std::vector<Split> answered;
    for (const Split& x : s) {
        if (!x.refused) answered.push_back(x);
    }
    int within = 0;
    for (const Split& x : answered) within += std::abs(x.total) <= 2.0 * x.sigma ? 1 : 0;
    const auto term = [&](double Split::*field) {
        return absl::StrFormat("%.2f (%+.2f)", MeanAbsOf(answered, field), MeanOf(answered, field));
    };
    std::vector<double> sigmas;
    for (const Split& x : answered) sigmas.push_back(x.sigma);
    const double median_sigma = sigmas.empty() ? 0.0 : Median(sigmas);
    return absl::StrFormat(
        "| %s | %.2f | %.2f | %s | %s | %s | %s | %.2f | %.2f | %.2f | %d/%d |\n", label,
        MeanAbsOf(answered, &Split::total), MaxAbsOf(answered, &Split::total), term(&Split::pose),
        term(&Split::empty), term(&Split::soil), term(&Split::grid), MeanAbs(row.capacity_pct),
        answered.empty() ? 0.0 : static_cast<double>(within) / answered.size(), median_sigma,
        row.refused + row.register_failures, static_cast<int>(s.size()) + row.register_failures);
}

void KvLine(std::ostream& kv, const std::string& family, int scans, int seed, double fill,
            double noise, const Split& s) {
    kv << absl::StrFormat(
        "budget family=%s scans=%d seed=%d fill=%.2f noise_m=%.3f refused=%d total=%.3f "
        "pose=%.3f empty=%.3f soil=%.3f grid=%.3f sigma=%.3f pose_sigma=%.3f height_mm=%.2f "
        "tilt_deg=%.3f "
        "empty_wall=%.3f empty_flat=%.3f scan_wall=%.3f scan_flat=%.3f\n",
        family, scans, seed, fill, noise, s.refused ? 1 : 0, s.total, s.pose, s.empty, s.soil,
        s.grid, s.sigma, s.pose_sigma, s.height_mm, s.tilt_deg, s.empty_wall, s.empty_flat,
        s.scan_wall, s.scan_flat);
}

constexpr const char* kHeader =
    "| %s | mean \\|err\\| | max \\|err\\| | pose | empty surface | soil surface | grid | "
    "capacity \\|err\\| | 2-sigma | median 1-sigma | refused |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|\n";

}  // namespace

std::string BudgetTable(int seeds, std::ostream& kv) {
    std::map<std::string, Row> by_family, by_noise;
    std::vector<std::string> family_order, noise_order;
    // Registration kinds: 1 or 2 empty scans, 0 the mesh; with the ToF camera of the families
    // table (its own noise: not in the noise table).
    struct Kind {
        int scans;
        bool tof;
    };
    Row unused_noise_row;
    for (const Kind k :
         {Kind{1, false}, Kind{2, false}, Kind{0, false}, Kind{1, true}, Kind{2, true}}) {
        const int scans = k.scans;
        for (const sim::ContainerFamily family : sim::AllFamilies()) {
            const std::string name = sim::FamilyName(family);
            const std::string kind = (scans > 0 ? absl::StrFormat("%d empty", scans) : "mesh") +
                                     std::string(k.tof ? ", ToF camera" : "");
            const std::string family_key = absl::StrFormat("%s | %s", name, kind);
            if (!by_family.count(family_key)) family_order.push_back(family_key);
            Row& row = by_family[family_key];
            for (int seed = 1; seed <= seeds; ++seed) {
                Setup setup = FamilySetup(family, seed, std::max(scans, 1));
                setup.from_mesh = scans == 0;
                if (k.tof) setup.tof_camera = sim::TypicalTofCamera();
                const std::string noise_key =
                    absl::StrFormat("%.0f cm | %s", 100.0 * setup.sensor.range_noise_sigma_m, kind);
                if (!k.tof && !by_noise.count(noise_key)) noise_order.push_back(noise_key);
                Row& noise_row = k.tof ? unused_noise_row : by_noise[noise_key];
                const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
                if (!reg.model.ok()) {
                    row.register_failures += static_cast<int>(kFillShares.size());
                    noise_row.register_failures += static_cast<int>(kFillShares.size());
                    kv << "budget family=" << name << (k.tof ? "-tof" : "") << " scans=" << scans
                       << " seed=" << seed << " register_error=" << reg.model.status().message()
                       << "\n";
                    continue;
                }
                const double capacity = 100.0 *
                                        (reg.model->struck_capacity_m3 - reg.true_struck_m3) /
                                        reg.true_struck_m3;
                row.capacity_pct.push_back(capacity);
                noise_row.capacity_pct.push_back(capacity);
                const sim::ContainerGeometry geometry = sim::MakeContainer(*setup.shape);
                for (std::size_t f = 0; f < kFillShares.size(); ++f) {
                    sim::SoilSpec spec;
                    spec.fill_height_m = kFillShares[f] * geometry.depth_m;
                    spec.perturbation_m = setup.perturbation_m;
                    const sim::SoilSurface soil(geometry, spec, static_cast<uint64_t>(seed));
                    const sim::Scene scene =
                        FilledScan(setup, spec.fill_height_m, static_cast<uint64_t>(seed), f);
                    const Split s = SplitError(reg, geometry, soil, scene);
                    KvLine(kv, k.tof ? name + "-tof" : name, scans, seed, kFillShares[f],
                           setup.sensor.range_noise_sigma_m, s);
                    for (Row* r : {&row, &noise_row}) {
                        r->splits.push_back(s);
                        if (s.refused) ++r->refused;
                    }
                }
            }
        }
    }
    // Stereo: the rendered rig of the stereo table, calibrated from chessboards; the truth in
    // the rectified left frame (the calibration's R1 on the rendering's left camera).
    std::vector<std::string> stereo_order;
    for (const sim::ContainerKind kind :
         {sim::ContainerKind::kPaperBucket, sim::ContainerKind::kExcavatorBucket}) {
        const std::string key = ContainerName(kind) + " | stereo";
        stereo_order.push_back(key);
        Row& row = by_family[key];
        const StereoSetup setup = PaperRig(kind);
        const sim::ContainerGeometry geometry = sim::MakeContainer(kind);
        for (int seed = 1; seed <= std::min(seeds, 3); ++seed) {
            const auto s = static_cast<uint64_t>(seed);
            const auto calibration = CalibrateRig(setup, s);
            const auto stereo = calibration.ok() ? stereo::StereoReconstructor::Create(*calibration)
                                                 : calibration.status();
            if (!stereo.ok()) {
                row.register_failures += static_cast<int>(kFillShares.size());
                continue;
            }
            const StereoRegistered sreg = RegisterStereoEmpty(setup, *stereo, s);
            if (!sreg.model.ok()) {
                row.register_failures += static_cast<int>(kFillShares.size());
                kv << "budget stereo=" << key << " seed=" << seed
                   << " register_error=" << sreg.model.status().message() << "\n";
                continue;
            }
            const RenderedPair empty_pair = RenderPair(setup, 0.0, s, s * 1000);
            const Pose rect_left(calibration->R1);
            RegisteredModel reg{sreg.model->model, sreg.true_struck_m3, 0.0};
            reg.sim_to_model = (rect_left * empty_pair.scene.T_left_container).inverse() *
                               reg.model->opening.T_scan_container;
            row.capacity_pct.push_back(
                100.0 * (reg.model->struck_capacity_m3 - reg.true_struck_m3) / reg.true_struck_m3);
            for (std::size_t f = 0; f < kFillShares.size(); ++f) {
                sim::SoilSpec spec;
                spec.fill_height_m = std::min(kFillShares[f], 1.15) * geometry.depth_m;
                const sim::SoilSurface soil(geometry, spec, s);
                const RenderedPair pair =
                    RenderPair(setup, spec.fill_height_m, s, s * 1000 + 1 + f);
                const auto cloud = stereo->Reconstruct(pair.left_png, pair.right_png);
                if (!cloud.ok()) continue;
                sim::Scene scene;
                scene.points = cloud->points;
                scene.T_scan_container = rect_left * pair.scene.T_left_container;
                scene.true_volume_m3 = pair.scene.true_volume_m3;
                const Split split =
                    SplitError(reg, geometry, soil, scene, pipeline::StereoDefaults());
                KvLine(kv, key, 0, seed, kFillShares[f], 0.0, split);
                row.splits.push_back(split);
                if (split.refused) ++row.refused;
            }
        }
    }
    std::ostringstream md;
    md << "## Error budget (every family, sensor and registration kind, " << seeds
       << " seeds, fills 0-130%)\n\n"
          "Each estimate of the families table's set-ups split by substituting the simulator's "
          "truth for one stage at a time: **pose** = the estimate at the found pose minus the "
          "one at the true pose; **empty surface** = that minus the same with the true empty "
          "surface; **soil surface** = that minus the true soil surface integrated over the "
          "same grid; **grid** = that minus the true volume (the grid's quadrature). The terms "
          "sum to the error (before the answer's clip at 0). Each cell: mean |term| (mean "
          "signed term), in % of the true struck capacity. Capacity: the registered struck "
          "capacity's error. 2-sigma: the share of answers within 2 reported sigmas.\n\n"
       << absl::StrFormat(kHeader, "family | registration");
    for (const std::string& key : family_order) md << FormatRow(key, by_family[key]);
    md << "\nStereo (the rendered 640x480 rig of the stereo table, 10 cm baseline, chessboard "
          "calibration, registered from one pair with clicked pixel corners; up to 3 seeds, fills "
          "0-115%):\n\n"
       << absl::StrFormat(kHeader, "container | sensor");
    for (const std::string& key : stereo_order) md << FormatRow(key, by_family[key]);
    md << "\nThe same by the sensor's range noise:\n\n"
       << absl::StrFormat(kHeader, "noise | registration");
    std::sort(noise_order.begin(), noise_order.end());
    for (const std::string& key : noise_order) md << FormatRow(key, by_noise[key]);
    md << "\n";
    return md.str();
}

std::string PoseTable(int seeds, std::ostream& kv) {
    Setup setup;
    setup.sensor = PaperSensor(setup.container);
    std::vector<double> height, tilt;
    int refused = 0, count = 0;
    const sim::ContainerGeometry geometry = sim::MakeContainer(setup.container);
    for (int seed = 1; seed <= seeds; ++seed) {
        const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
        if (!reg.model.ok()) continue;
        for (std::size_t f = 0; f < kFillShares.size(); ++f) {
            const double fill_m = kFillShares[f] * geometry.depth_m;
            const sim::Scene scene = FilledScan(setup, fill_m, static_cast<uint64_t>(seed), f);
            ++count;
            const auto e = pipeline::EstimateVolume(*reg.model, scene.points, {});
            if (!e.ok()) {
                ++refused;
                kv << "pose seed=" << seed << " fill=" << kFillShares[f]
                   << " refused=" << e.status().message() << "\n";
                continue;
            }
            const Pose T_true = scene.T_scan_container * reg.sim_to_model;
            const Pose delta = T_true.inverse() * e->alignment.T_scan_container;
            height.push_back(1000.0 * std::abs(delta.translation().z()));
            tilt.push_back(std::acos(std::clamp(delta.linear()(2, 2), -1.0, 1.0)) * 180.0 / kPi);
            kv << absl::StrFormat("pose seed=%d fill=%.2f height_mm=%.2f tilt_deg=%.3f\n", seed,
                                  kFillShares[f], 1000.0 * delta.translation().z(), tilt.back());
        }
    }
    const auto q = [](std::vector<double> v, double p) { return v.empty() ? 0.0 : Quantile(v, p); };
    std::ostringstream md;
    md << "## Pose (paper bucket, 4 cm noise, 0.5 deg, " << seeds
       << " seeds x 6 fills)\n\nThe found container pose against the true one: the opening "
          "centre's height error along the opening normal and the tilt of the normal.\n\n"
          "| estimates | refused | height error median (mm) | p95 (mm) | tilt median (deg) | p95 "
          "(deg) |\n|---|---|---|---|---|---|\n"
       << absl::StrFormat("| %d | %d | %.2f | %.2f | %.3f | %.3f |\n\n", count, refused,
                          q(height, 0.5), q(height, 0.95), q(tilt, 0.5), q(tilt, 0.95))
       << "Target: median <= 2 mm, p95 <= 4 mm.\n\n";
    return md.str();
}

}  // namespace soilvol::bench
