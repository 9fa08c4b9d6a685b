#include "bench/family_tables.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/budget.hpp"
#include "bench/trial.hpp"
#include "core/align/icp.hpp"
#include "core/cloud/preprocess.hpp"
#include "core/pipeline/registration.hpp"
#include "core/sim/scene.hpp"
#include "core/sim/soil_surface.hpp"
#include "core/sim/tof_sensor.hpp"
#include "core/volume/heightmap_volume.hpp"

namespace soilvol::bench {
namespace {

constexpr double kLitre = 1000.0;
constexpr std::array<double, 6> kFillShares = {0.0, 0.25, 0.5, 0.75, 1.0, 1.3};

struct Cell {
    std::vector<double> error_pct;  // of struck capacity
    std::vector<double> true_l;
    int within_2_sigma = 0;
    int failures = 0;
};

double MeanAbs(const std::vector<double>& v) {
    double s = 0.0;
    for (const double x : v) s += std::abs(x);
    return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}
double MaxAbs(const std::vector<double>& v) {
    double m = 0.0;
    for (const double x : v) m = std::max(m, std::abs(x));
    return m;
}
double Mean(const std::vector<double>& v) {
    double s = 0.0;
    for (const double x : v) s += x;
    return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

struct FamilyRows {
    std::string detail;
    std::string summary;
    std::string seen;  ///< the multi-sensor table's rows: errors and the share the scans saw
};

// Which sensor takes the scans: the seed's ray-grid sensor, or a sensor profile from the seed's
// viewpoint.
// The bridge profiles: spinning lidars on a bridge over the container, the near one alone or
// with its mirror on the far side.
enum class Profile { kSeedSensor, kTofCamera, kSpinningLidar, kBridgeOneLidar, kBridgeTwoLidars };

std::string ProfileName(Profile profile, bool for_kv) {
    switch (profile) {
        case Profile::kSeedSensor:
            return "";
        case Profile::kTofCamera:
            return for_kv ? "-tof" : ", ToF camera";
        case Profile::kSpinningLidar:
            return for_kv ? "-lidar" : ", spinning lidar";
        case Profile::kBridgeOneLidar:
            return for_kv ? "-bridge1" : ", one lidar on a bridge";
        case Profile::kBridgeTwoLidars:
            return for_kv ? "-bridge2" : ", two lidars on a bridge";
    }
    return "";
}

// The set-up of `seed` scanned as `profile` says.
void ApplyProfile(Profile profile, int seed, Setup& setup) {
    switch (profile) {
        case Profile::kSeedSensor:
            return;
        case Profile::kTofCamera:
            setup.tof_camera = sim::TypicalTofCamera();
            return;
        case Profile::kSpinningLidar:
            setup.sensor = sim::TypicalSpinningLidar(setup.sensor);
            return;
        case Profile::kBridgeOneLidar:
        case Profile::kBridgeTwoLidars: {
            const std::vector<sim::SensorSpec> bridge =
                sim::BridgeViewpoints(*setup.shape, static_cast<uint64_t>(seed));
            setup.sensor = sim::TypicalSpinningLidar(bridge[0]);
            if (profile == Profile::kBridgeTwoLidars) {
                setup.more_sensors = {sim::TypicalSpinningLidar(bridge[1])};
            }
            return;
        }
    }
}

// `empty_scans` 0: registered from the family member's mesh.
FamilyRows RunFamilies(int seeds, int empty_scans, std::ostream& kv,
                       Profile profile = Profile::kSeedSensor) {
    const std::string registration = empty_scans > 0 ? std::to_string(empty_scans) : "mesh";
    const std::string kind = registration + ProfileName(profile, false);
    const std::string kv_kind = registration + ProfileName(profile, true);
    std::ostringstream md, summary, seen_rows;
    for (const sim::ContainerFamily family : sim::AllFamilies()) {
        const std::string name = sim::FamilyName(family);
        std::array<Cell, kFillShares.size()> cells;
        std::vector<double> capacity_pct, observed, seen;
        int warned = 0;
        for (int seed = 1; seed <= seeds; ++seed) {
            Setup setup = FamilySetup(family, seed, std::max(empty_scans, 1));
            setup.from_mesh = empty_scans == 0;
            ApplyProfile(profile, seed, setup);
            const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
            const double struck_l = reg.true_struck_m3 * kLitre;
            if (!reg.model.ok()) {
                for (Cell& c : cells) ++c.failures;
                kv << "family=" << name << " scans=" << kv_kind << " seed=" << seed
                   << " register_error=" << reg.model.status().message() << "\n";
                continue;
            }
            if (!pipeline::CapacityWarnings(*reg.model, 0.01).empty()) ++warned;
            capacity_pct.push_back(100.0 * (reg.model->struck_capacity_m3 - reg.true_struck_m3) /
                                   reg.true_struck_m3);
            observed.push_back(reg.model->observed_share);
            for (std::size_t f = 0; f < kFillShares.size(); ++f) {
                const double fill_m = kFillShares[f] * sim::MakeContainer(*setup.shape).depth_m;
                const sim::MultiSensorScene rig =
                    FilledRigScan(setup, fill_m, static_cast<uint64_t>(seed), f);
                const sim::Scene& scene = rig.scene;
                const auto e =
                    Estimate(*reg.model, scene.points, volume::Method::kHeightmap, 0.0, rig.more);
                Cell& c = cells[f];
                c.true_l.push_back(scene.true_volume_m3 * kLitre);
                if (!e.ok()) {
                    ++c.failures;
                    kv << "family=" << name << " scans=" << kv_kind << " seed=" << seed
                       << " fill=" << kFillShares[f] << " error=" << e.status().message() << "\n";
                    continue;
                }
                const double err_l = (e->volume_m3 - scene.true_volume_m3) * kLitre;
                c.error_pct.push_back(100.0 * err_l / struck_l);
                if (std::abs(err_l) <= 2.0 * e->uncertainty_m3 * kLitre) ++c.within_2_sigma;
                seen.push_back(e->volume.scan_observed_share);
                kv << absl::StrFormat(
                    "family=%s scans=%s seed=%d fill=%.2f noise_m=%.3f true_l=%.1f estimate_l=%.1f "
                    "err_pct_struck=%.3f sigma_l=%.2f below=%d both=%d fitness=%.3f "
                    "through=%.3f seen=%.3f\n",
                    name, kv_kind, seed, kFillShares[f], setup.sensor.range_noise_sigma_m,
                    scene.true_volume_m3 * kLitre, e->volume_m3 * kLitre, 100.0 * err_l / struck_l,
                    e->uncertainty_m3 * kLitre, e->volume.cells.below_empty,
                    e->volume.cells.both_measured, e->alignment.fitness, e->seen_through.Share(),
                    e->volume.scan_observed_share);
            }
        }
        std::vector<double> all;
        int within = 0, count = 0;
        for (std::size_t f = 0; f < kFillShares.size(); ++f) {
            const Cell& c = cells[f];
            all.insert(all.end(), c.error_pct.begin(), c.error_pct.end());
            within += c.within_2_sigma;
            count += static_cast<int>(c.error_pct.size());
            md << absl::StrFormat(
                "| %s | %s | %.0f%% | %.1f | %+.2f | %.2f | %.2f | %d/%d | %d |\n", name, kind,
                100.0 * kFillShares[f], Mean(c.true_l), Mean(c.error_pct), MeanAbs(c.error_pct),
                MaxAbs(c.error_pct), c.within_2_sigma, static_cast<int>(c.error_pct.size()),
                c.failures);
        }
        const double coverage = count > 0 ? static_cast<double>(within) / count : 0.0;
        int refused = 0;
        for (const Cell& c : cells) refused += c.failures;
        if (all.empty()) {  // every estimate refused: no figure to show
            seen_rows << absl::StrFormat("| %s | %s | - | - | - | - | - | %d/%d |\n", name, kind,
                                         refused, seeds * static_cast<int>(kFillShares.size()));
        } else {
            seen_rows << absl::StrFormat(
                "| %s | %s | %.2f | %.2f | %.2f | %.2f | %.3f (%.3f) | %d/%d |\n", name, kind,
                MeanAbs(all), MaxAbs(all), MeanAbs(cells[0].error_pct), coverage, Mean(seen),
                *std::min_element(seen.begin(), seen.end()), refused,
                seeds * static_cast<int>(kFillShares.size()));
        }
        if (capacity_pct.empty()) {  // no seed registered: nothing to average
            summary << absl::StrFormat(
                "| %s | %s | - | - | - | - | registration refused (%d of %d) "
                "| - | - |\n",
                name, kind, seeds, seeds);
        } else {
            summary << absl::StrFormat(
                "| %s | %s | %.2f | %.2f | %.2f | %.2f | %.2f (%.2f) | %.2f | %d/%d |\n", name,
                kind, MeanAbs(all), MaxAbs(all), MeanAbs(cells[0].error_pct), coverage,
                MeanAbs(capacity_pct), MaxAbs(capacity_pct), Mean(observed), warned,
                static_cast<int>(capacity_pct.size()));
        }
        kv << absl::StrFormat(
            "family=%s scans=%s mean_abs_pct=%.3f max_abs_pct=%.3f empty_pct=%.3f "
            "coverage_2sigma=%.3f capacity_abs_pct=%.3f observed=%.3f\n",
            name, kv_kind, MeanAbs(all), MaxAbs(all), MeanAbs(cells[0].error_pct), coverage,
            MeanAbs(capacity_pct), Mean(observed));
    }
    return {md.str(), summary.str(), seen_rows.str()};
}

struct Move {
    const char* name;
    double angle_deg;
    Eigen::Vector3d axis;
    Eigen::Vector3d shift_m;
};

// Container frame: z out of the opening, x along its length, y across (a bucket curls about x).
const std::array<Move, 13> kMoves = {{
    {"yaw 20 deg", 20.0, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()},
    {"yaw 40 deg", 40.0, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()},
    {"yaw 60 deg", 60.0, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Zero()},
    {"curl 20 deg", 20.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()},
    {"curl 40 deg", 40.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()},
    {"curl -30 deg", -30.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d::Zero()},
    {"roll 15 deg", 15.0, Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero()},
    {"roll 30 deg", 30.0, Eigen::Vector3d::UnitY(), Eigen::Vector3d::Zero()},
    {"shift 0.5 m", 0.0, Eigen::Vector3d::UnitZ(), {0.5, 0.0, 0.0}},
    {"shift 1 m", 0.0, Eigen::Vector3d::UnitZ(), {0.0, 0.8, 0.6}},
    {"yaw 45 deg + 0.5 m", 45.0, Eigen::Vector3d::UnitZ(), {0.3, -0.4, 0.0}},
    {"45 deg / 0.5 m, oblique", 45.0, Eigen::Vector3d(1.0, 1.0, 1.0).normalized(), {0.3, 0.3, 0.3}},
    {"60 deg / 1 m, oblique", 60.0, Eigen::Vector3d(1.0, -2.0, 1.0).normalized(), {0.6, -0.5, 0.6}},
}};

struct MoveCount {
    int right = 0, within_sigma = 0, wrong = 0, refused = 0;
    double worst_wrong_pct = 0.0;
};

}  // namespace

std::string MovesTable(int seeds, std::ostream& kv) {
    std::array<MoveCount, kMoves.size()> blind, searched, known;
    for (const sim::ContainerFamily family : sim::AllFamilies()) {
        for (int seed = 1; seed <= seeds; ++seed) {
            Setup setup = FamilySetup(family, seed);
            const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
            if (!reg.model.ok()) continue;
            const double struck_l = reg.true_struck_m3 * kLitre;
            for (std::size_t m = 0; m < kMoves.size(); ++m) {
                const Move& move = kMoves[m];
                setup.move = Pose::Identity();
                setup.move.linear() =
                    Eigen::AngleAxisd(move.angle_deg * 3.14159265358979 / 180.0, move.axis)
                        .toRotationMatrix();
                setup.move.translation() = move.shift_m;
                const double fill_m = 0.5 * sim::MakeContainer(*setup.shape).depth_m;
                const sim::Scene scene = FilledScan(setup, fill_m, static_cast<uint64_t>(seed), m);
                // 0: from the registration's pose; 1: the same with the global search on;
                // 2: from the true pose.
                for (int with_pose = 0; with_pose < 3; ++with_pose) {
                    pipeline::EstimateConfig config;
                    if (with_pose == 1) config.global_search_below_fitness = 0.3;
                    if (with_pose == 2) {
                        config.initial_T_scan_container = scene.T_scan_container * reg.sim_to_model;
                    }
                    const auto e = pipeline::EstimateVolume(*reg.model, scene.points, config);
                    MoveCount& count = with_pose == 2   ? known[m]
                                       : with_pose == 1 ? searched[m]
                                                        : blind[m];
                    std::string outcome;
                    if (!e.ok()) {
                        ++count.refused;
                        outcome =
                            "refused " + std::string(absl::StatusCodeToString(e.status().code()));
                    } else {
                        const double err_pct =
                            100.0 * (e->volume_m3 - scene.true_volume_m3) * kLitre / struck_l;
                        const double sigma_pct = 100.0 * e->uncertainty_m3 * kLitre / struck_l;
                        if (std::abs(err_pct) <= 3.0) {
                            ++count.right;
                        } else if (std::abs(err_pct) <= 3.0 * sigma_pct) {
                            ++count.within_sigma;
                        } else {
                            ++count.wrong;
                            count.worst_wrong_pct =
                                std::max(count.worst_wrong_pct, std::abs(err_pct));
                        }
                        const pipeline::PoseDifference off =
                            pipeline::DifferenceOf(scene.T_scan_container * reg.sim_to_model,
                                                   e->alignment.T_scan_container);
                        outcome = absl::StrFormat(
                            "err_pct_struck=%.2f sigma_pct=%.2f scan_observed=%.2f fitness=%.2f "
                            "pose_sigma_m=%.4f below=%d both=%d through=%.3f pose_off_m=%.3f "
                            "pose_off_deg=%.2f",
                            err_pct, sigma_pct, e->volume.scan_observed_share, e->alignment.fitness,
                            e->alignment.z_sigma_m, e->volume.cells.below_empty,
                            e->volume.cells.both_measured, e->seen_through.Share(), off.distance_m,
                            off.rotation_deg);
                    }
                    kv << "moves family=" << sim::FamilyName(family) << " seed=" << seed
                       << " move=\"" << move.name << "\" initial_pose=" << with_pose << " "
                       << outcome << "\n";
                }
            }
        }
    }
    std::ostringstream md;
    md << "## Large moves (every family, " << seeds
       << " seeds, half full)\n\nThe container moves between the empty scan and the filled one "
          "(container frame: yaw about the opening normal, curl about its length, roll about "
          "its width). Without an initial pose the estimator starts from the registration's "
          "(local ICP only, the default; or with the FPFH + RANSAC global search, "
          "`global_search_below_fitness` 0.3); with one it starts from the true pose, as a "
          "machine's kinematics would give it. Right: within 3% of struck capacity. Within 3 "
          "sigma: off by more, but by at most 3 reported sigmas (the answer says it is unsure). "
          "Wrong: off by more than both (issue 27's gate: must be 0). Refused: "
          "FailedPrecondition.\n\n"
       << "| move | no initial pose: right / within 3 sigma / wrong / refused (worst wrong %) | "
          "with the global search | true initial pose |\n|---|---|---|---|\n";
    const auto cell = [](const MoveCount& c) {
        return absl::StrFormat("%d / %d / %d / %d (%.1f)", c.right, c.within_sigma, c.wrong,
                               c.refused, c.worst_wrong_pct);
    };
    MoveCount total[3];
    for (std::size_t m = 0; m < kMoves.size(); ++m) {
        md << "| " << kMoves[m].name << " | " << cell(blind[m]) << " | " << cell(searched[m])
           << " | " << cell(known[m]) << " |\n";
        const MoveCount* rows[3] = {&blind[m], &searched[m], &known[m]};
        for (int i = 0; i < 3; ++i) {
            total[i].right += rows[i]->right;
            total[i].within_sigma += rows[i]->within_sigma;
            total[i].wrong += rows[i]->wrong;
            total[i].refused += rows[i]->refused;
            total[i].worst_wrong_pct = std::max(total[i].worst_wrong_pct, rows[i]->worst_wrong_pct);
        }
    }
    md << "| **all** | " << cell(total[0]) << " | " << cell(total[1]) << " | " << cell(total[2])
       << " |\n";
    md << "\n";
    return md.str();
}

std::string SensorsTable(int seeds, std::ostream& kv) {
    const FamilyRows one = RunFamilies(seeds, 1, kv, Profile::kBridgeOneLidar);
    const FamilyRows two = RunFamilies(seeds, 1, kv, Profile::kBridgeTwoLidars);
    std::ostringstream md;
    md << "### Several sensors per scan\n\n"
       << "Spinning lidars (core/sim `TypicalSpinningLidar`) on a bridge over the container "
          "(core/sim `BridgeViewpoints`: 60-75 deg elevation, looking across it, one each "
          "side); every scan, the empty one included, is taken by the near lidar alone or by "
          "both together (one call: `Scan.additional_sensors`, each cloud with its own sensor "
          "pose). Seen: the share of the opening the filled scan's returns cover (mean over "
          "the fills, and the least).\n\n"
       << "| family | registration, sensors | mean \\|err\\| % | max \\|err\\| % | empty, "
          "mean \\|err\\| % | 2-sigma | seen, mean (least) | refused |\n"
          "|---|---|---|---|---|---|---|---|\n"
       << one.seen << two.seen
       << "\nTarget (issue 29): two sensors on a bridge over a truck body (flared body): max "
          "\\|err\\| <= 1% of struck, seen >= 0.98.\n\n";
    return md.str();
}

std::string FamilyTable(int seeds, std::ostream& kv) {
    std::ostringstream md;
    md << "## Container families (default estimator, automatic cell size)\n\n"
       << "Each seed draws a new container of the family (core/sim `RandomShape`), a new "
          "viewpoint (50-65 deg elevation, +-45 deg azimuth), a sensor noise of 1/2/3/4 cm, a "
          "resolution of 0.25-0.5 deg and 0/1/2% outliers; the container moves up to 5 deg / "
          "10 cm between the empty scans and each filled scan. The model is registered from one "
          "empty scan, or from two: the second sees the container turned half way round (what "
          "the first view's near walls hid). Errors are in % of the true struck capacity; "
          "2-sigma is the share of estimates with |error| <= 2 x the reported 1-sigma. Fill is "
          "the soil level as a share of the depth; 130% heaps above the rim. Observed: the share "
          "of the opening the empty scans saw. Mesh: registered from the member's exact mesh "
          "(no empty scan), placed where the first empty scan sees it, with the sensor's "
          "noise. ToF camera: every scan by a typical ToF camera (core/sim "
          "`TypicalTofCamera`: 640x480 over 67 deg, 3 mm at 1 m growing with range and falling "
          "with "
          "amplitude, flying pixels at depth edges, multipath up to 2 cm in concave corners) "
          "from the seed's viewpoint, its depth image back-projected with the flying-pixel "
          "filter, as the service does. Spinning lidar: core/sim `TypicalSpinningLidar` (rings "
          "1.33 deg apart, 0.2 deg along each, 2 cm noise) from the seed's viewpoint. Rings "
          "farther apart than the alignment's 8 cm smoothing leave every neighbourhood one ring "
          "(a line, whose normal matches nothing); the registration measures the sensor's rows "
          "(cloud::MeasureAngularSampling) and smooths over 1.25 row gaps at the median range "
          "(the flared body, seen from farthest: 12-16 cm), which lets its second empty scan "
          "align (it was refused on 5 of 5 seeds before).\n\n";
    const FamilyRows one = RunFamilies(seeds, 1, kv);
    const FamilyRows two = RunFamilies(seeds, 2, kv);
    const FamilyRows mesh = RunFamilies(seeds, 0, kv);
    const FamilyRows tof_one = RunFamilies(seeds, 1, kv, Profile::kTofCamera);
    const FamilyRows tof_two = RunFamilies(seeds, 2, kv, Profile::kTofCamera);
    const FamilyRows lidar = RunFamilies(seeds, 2, kv, Profile::kSpinningLidar);
    md << "| family | registration | mean \\|err\\| % | max \\|err\\| % | empty, mean \\|err\\| % "
          "| "
          "2-sigma | registered capacity, mean \\|err\\| % (max) | observed | warned |\n"
          "|---|---|---|---|---|---|---|---|---|\n"
       << one.summary << two.summary << mesh.summary << tof_one.summary << tof_two.summary
       << lidar.summary
       << "\nTargets (issue 27): 2 empty scans or a mesh: mean |err| <= 0.5%, max <= 1%, empty "
          "<= 0.2%; 1 empty scan: mean <= 0.7%, max <= 2%, or the registration warns; 2-sigma "
          "0.90-0.98. Issue 29: with the ToF camera, mean <= 0.7%, max <= 2% on every family."
          "\n\n"
       << "Per fill:\n\n"
       << "| family | registration | fill | true (L, mean) | mean err % | mean \\|err\\| % | "
          "max \\|err\\| % | 2-sigma | refused |\n|---|---|---|---|---|---|---|---|---|\n"
       << one.detail << two.detail << mesh.detail << tof_one.detail << tof_two.detail
       << lidar.detail << "\n"
       << SensorsTable(seeds, kv);
    return md.str();
}

}  // namespace soilvol::bench

namespace soilvol::bench {

int FamilyCase(const FamilyCaseOptions& options, std::ostream& out) {
    const int family_index = options.family_index, seed = options.seed;
    const double fill_share = options.fill_share;
    const auto& families = sim::AllFamilies();
    if (family_index < 0 || family_index >= static_cast<int>(families.size())) return 2;
    Setup setup =
        FamilySetup(families[static_cast<std::size_t>(family_index)], seed, options.empty_scans);
    if (options.jitter_deg >= 0.0) setup.jitter = {options.jitter_deg, 0.0};
    if (options.noise_m > 0.0) setup.sensor.range_noise_sigma_m = options.noise_m;
    const sim::ContainerGeometry geometry = sim::MakeContainer(*setup.shape);
    const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
    if (!reg.model.ok()) {
        out << "register: " << reg.model.status() << "\n";
        return 1;
    }
    const sim::Scene scene =
        FilledScan(setup, fill_share * geometry.depth_m, static_cast<uint64_t>(seed), 9);
    const auto e = Estimate(*reg.model, scene.points, volume::Method::kHeightmap, 0.0);
    {
        align::AlignConfig ac;
        ac.max_iterations = 0;
        const cloud::PreprocessResult pre = cloud::Preprocess(scene.points, {});
        const auto at_truth = model::AlignModel(*reg.model, pre.points, scene.T_scan_container, ac);
        out << "at the true pose: fitness " << at_truth.fitness << " rmse " << at_truth.rmse_m
            << " targets " << at_truth.target_points << " model points "
            << reg.model->alignment_points.size() << "\n";
    }
    out << absl::StrFormat(
        "%s %.2fx%.2fx%.2f m walls %.0f/%.0f deg; sensor %.1f m el %.0f az %.0f noise %.3f res "
        "%.2f\nstruck true %.1f L model %.1f L; structure radius %.3f m, noise %.4f m\n",
        sim::FamilyName(setup.shape->family), setup.shape->length_m, setup.shape->width_m,
        setup.shape->depth_m, setup.shape->front_wall_deg, setup.shape->back_wall_deg,
        setup.sensor.distance_m, setup.sensor.elevation_deg, setup.sensor.azimuth_deg,
        setup.sensor.range_noise_sigma_m, setup.sensor.angular_resolution_deg,
        reg.true_struck_m3 * kLitre, reg.model->struck_capacity_m3 * kLitre,
        reg.model->structure_radius_m, reg.model->noise_sigma_m);
    if (!e.ok()) {
        out << "estimate: " << e.status() << "\n";
        return 1;
    }
    const Pose delta = scene.T_scan_container.inverse() * e->alignment.T_scan_container;
    out << absl::StrFormat(
        "true %.1f L estimate %.1f L (raw %.1f L) sigma %.1f L; fitness %.3f rmse %.4f; pose error "
        "%.4f %.4f "
        "%.4f m, %.3f deg\n",
        scene.true_volume_m3 * kLitre, e->volume_m3 * kLitre, e->volume.raw_volume_m3 * kLitre,
        e->uncertainty_m3 * kLitre, e->alignment.fitness, e->alignment.rmse_m,
        delta.translation().x(), delta.translation().y(), delta.translation().z(),
        Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / 3.14159265358979);
    {
        // The same scan at the registration's own pose, no ICP: with no movement (--jitter-deg
        // 0) this separates the estimator's error from the alignment's.
        pipeline::EstimateConfig fixed;
        fixed.align.max_iterations = 0;
        fixed.gate.require_converged = false;
        fixed.initial_T_scan_container = reg.model->opening.T_scan_container;
        const auto at_reg = pipeline::EstimateVolume(*reg.model, scene.points, fixed);
        if (at_reg.ok()) {
            out << absl::StrFormat("at the registration pose, no ICP: raw %.1f L\n",
                                   at_reg->volume.raw_volume_m3 * kLitre);
        } else {
            out << "at the registration pose: " << at_reg.status() << "\n";
        }
    }
    // Per-cell error of the soil height [cm] against the truth: rows from +y down.
    const volume::Grid& g = e->volume.grid;
    const auto empty_surface = model::ModelEmptySurface(*reg.model, g, {});
    const auto empty = empty_surface.ok() ? absl::StatusOr<volume::SurfaceMap>(empty_surface->map)
                                          : empty_surface.status();
    if (empty.ok()) {
        // Volume errors of the empty surface [L] against the true cell means: over the cells
        // it measured, and the rest.
        std::vector<double> truth(g.weight.size(), 0.0);
        for (std::size_t k = 0; k < g.weight.size(); ++k) {
            if (g.weight[k] > 0.0) {
                truth[k] =
                    TrueEmptyCell(g, reg.model->opening.polygon, k, geometry, reg.sim_to_model);
            }
        }
        double measured_l = 0.0, unmeasured_l = 0.0;
        for (std::size_t k = 0; k < g.weight.size(); ++k) {
            if (g.weight[k] <= 0.0) continue;
            const double err = g.weight[k] * kLitre * (empty->height[k] - truth[k]);
            (empty->support[k] > 0 ? measured_l : unmeasured_l) += err;
        }
        std::size_t cavity_points = 0;
        for (const WeightedCloud& c : reg.model->cavity) cavity_points += c.points.size();
        out << absl::StrFormat(
            "empty surface volume error: measured cells %+.1f L, the others %+.1f L; the cavity "
            "keeps %zu of the %zu inside returns (the rest lie within %.3f m of the structure)\n",
            measured_l, unmeasured_l, cavity_points, reg.model->inside.size(),
            reg.model->structure_radius_m);
        out << "empty surface error [cm]\n";
        for (int r = g.rows - 1; r >= 0; --r) {
            for (int c = 0; c < g.cols; ++c) {
                const auto uk = static_cast<std::size_t>(r * g.cols + c);
                if (g.weight[uk] <= 0.0) continue;
                out << absl::StrFormat("%5.0f%s", 100.0 * (empty->height[uk] - truth[uk]),
                                       empty->support[uk] > 0 ? " " : "*");
            }
            out << "\n";
        }
    }
    const sim::SoilSurface soil(
        geometry,
        [&] {
            sim::SoilSpec s;
            s.fill_height_m = fill_share * geometry.depth_m;
            s.perturbation_m = setup.perturbation_m;
            return s;
        }(),
        static_cast<uint64_t>(seed));
    out << "cell " << g.cell_m << " m; per cell: error of soil height [cm] (* = interpolated)\n";
    for (int r = g.rows - 1; r >= 0; --r) {
        for (int c = 0; c < g.cols; ++c) {
            const int k = r * g.cols + c;
            const auto uk = static_cast<std::size_t>(k);
            if (g.weight[uk] <= 0.0) {
                out << "     .";
                continue;
            }
            const Eigen::Vector2d a = g.anchor[uk];
            const double inner = geometry.InnerSurfaceZ(a.x(), a.y());
            const double truth =
                soil.Empty() ? 0.0 : std::max(0.0, soil.SurfaceZ(a.x(), a.y()) - inner);
            const double err = 100.0 * (e->volume.soil_height_m[uk] - truth);
            out << absl::StrFormat(
                "%5.0f%s", err,
                e->volume.state[uk] == volume::CellState::kInterpolated ? "*" : " ");
        }
        out << "\n";
    }
    return 0;
}

}  // namespace soilvol::bench
