#include "bench/tables.hpp"

#include <malloc.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <sstream>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/trial.hpp"
#include "core/common/timer.hpp"
#include "core/io/cloud_codec.hpp"
#include "core/pipeline/parallelism.hpp"

namespace soilvol::bench {
namespace {

constexpr double kLitre = 1000.0;

struct Stats {
    std::vector<double> values;
    void Add(double v) { values.push_back(v); }
    double Mean() const {
        double s = 0.0;
        for (const double v : values) s += v;
        return values.empty() ? 0.0 : s / static_cast<double>(values.size());
    }
    double MeanAbs() const {
        double s = 0.0;
        for (const double v : values) s += std::abs(v);
        return values.empty() ? 0.0 : s / static_cast<double>(values.size());
    }
    double MaxAbs() const {
        double m = 0.0;
        for (const double v : values) m = std::max(m, std::abs(v));
        return m;
    }
    double Median() const {
        std::vector<double> v = values;
        if (v.empty()) return 0.0;
        std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
        return v[v.size() / 2];
    }
};

// Per-method outcome of one row over the seeds.
struct MethodStats {
    Stats estimate_l, error_l, cells_total, cells_empty, uncertainty_l;
    int failures = 0;
    std::string last_failure;
    void Add(const absl::StatusOr<pipeline::VolumeEstimate>& e, double true_l) {
        if (!e.ok()) {
            ++failures;
            last_failure = e.status().ToString();
            return;
        }
        estimate_l.Add(e->volume_m3 * kLitre);
        error_l.Add(e->volume_m3 * kLitre - true_l);
        uncertainty_l.Add(e->uncertainty_m3 * kLitre);
        cells_total.Add(e->volume.cells.total);
        cells_empty.Add(e->volume.cells.interpolated);
    }
};

struct PaperRow {
    double actual, estimate;
    const char* error;
};

std::string Pct(double v) { return absl::StrFormat("%.2f", v); }

}  // namespace

std::string FillTable(int seeds, std::ostream& kv) {
    const std::array<double, 9> fills_cm = {0, 10, 20, 30, 40, 45, 50, 55, 60};
    const std::array<PaperRow, 9> paper = {{{0.0, 17.6, "x"},
                                            {28.8, 26.2, "9.03"},
                                            {99.1, 90.8, "8.32"},
                                            {188.9, 183.3, "2.97"},
                                            {294.6, 285.3, "3.15"},
                                            {348.9, 336.7, "3.49"},
                                            {403.1, 384.4, "4.65"},
                                            {459.5, 438.3, "4.60"},
                                            {520.8, 498.1, "4.34"}}};
    Setup setup;
    setup.sensor = PaperSensor(setup.container);
    std::vector<Stats> truth(fills_cm.size());
    std::vector<MethodStats> heightmap(fills_cm.size()), paper_method(fills_cm.size());
    double struck_l = 0.0;
    int model_failures = 0;
    for (int seed = 1; seed <= seeds; ++seed) {
        const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
        struck_l = reg.true_struck_m3 * kLitre;
        if (!reg.model.ok()) {
            ++model_failures;
            kv << "table1_model_error=\"" << reg.model.status() << "\"\n";
            continue;
        }
        for (std::size_t f = 0; f < fills_cm.size(); ++f) {
            const sim::Scene scene =
                FilledScan(setup, fills_cm[f] / 100.0, static_cast<uint64_t>(seed), f);
            const double true_l = scene.true_volume_m3 * kLitre;
            truth[f].Add(true_l);
            heightmap[f].Add(Estimate(*reg.model, scene.points, volume::Method::kHeightmap, 0.10),
                             true_l);
            paper_method[f].Add(Estimate(*reg.model, scene.points, volume::Method::kPaper, 0.10),
                                true_l);
        }
    }
    std::ostringstream md;
    md << "## Table 1: fill levels (paper bucket, 10 cm grid, " << seeds << " seeds)\n\n"
       << "Struck capacity " << absl::StrFormat("%.1f", struck_l) << " L; 1% of it is "
       << absl::StrFormat("%.1f", struck_l / 100) << " L. Errors are estimate minus truth, "
       << "mean over seeds; |err| is the mean of absolute errors.\n\n"
       << "| fill (cm) | true (L) | HEIGHTMAP (L) | err (L) | \\|err\\| (L) | \\|err\\| % struck | "
          "\\|err\\| % of true | PAPER method (L) | \\|err\\| % of true | paper: actual / "
          "estimated "
          "(10^3 cm^3) | paper: err % |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (std::size_t f = 0; f < fills_cm.size(); ++f) {
        const double t = truth[f].Mean();
        const MethodStats& h = heightmap[f];
        const MethodStats& p = paper_method[f];
        const auto rel = [t](const Stats& err) {
            return t > 0.5 ? Pct(100.0 * err.MeanAbs() / t) : std::string("-");
        };
        md << absl::StrFormat(
            "| %.0f | %.1f | %.1f | %+.1f | %.1f | %s | %s | %.1f | %s | %.1f / %.1f | %s |\n",
            fills_cm[f], t, h.estimate_l.Mean(), h.error_l.Mean(), h.error_l.MeanAbs(),
            Pct(100.0 * h.error_l.MeanAbs() / struck_l), rel(h.error_l), p.estimate_l.Mean(),
            rel(p.error_l), paper[f].actual, paper[f].estimate, paper[f].error);
        kv << absl::StrFormat(
            "table1 fill_cm=%.0f true_l=%.2f heightmap_l=%.2f heightmap_err_l=%+.2f "
            "heightmap_abs_err_l=%.2f heightmap_sigma_l=%.2f paper_method_l=%.2f "
            "paper_method_err_l=%+.2f failures=%d/%d\n",
            fills_cm[f], t, h.estimate_l.Mean(), h.error_l.Mean(), h.error_l.MeanAbs(),
            h.uncertainty_l.Mean(), p.estimate_l.Mean(), p.error_l.Mean(), h.failures + p.failures,
            2 * seeds);
    }
    if (model_failures > 0)
        md << "\nModel registration failed for " << model_failures << " seeds.\n";
    md << "\n";
    return md.str();
}

std::string GridTable(int seeds, std::ostream& kv) {
    const std::array<double, 7> cells_cm = {15, 12, 10, 9, 7, 5, 3};
    const std::array<const char*, 7> paper = {
        "0/56 | 520.8 | 454.4 | 12.73",    "0/85 | 473.2 | 454.4 | 3.96",
        "3/126 | 498.1 | 454.4 | 8.75",    "3/138 | 498.2 | 454.4 | 8.77",
        "40/232 | 501.5 | 454.4 | 9.38",   "77/451 | 511.3 | 454.4 | 11.10",
        "1070/1156 | 447.1 | 454.4 | 1.67"};
    Setup setup;
    setup.sensor = PaperSensor(setup.container);
    std::vector<MethodStats> heightmap(cells_cm.size()), paper_method(cells_cm.size());
    Stats truth;
    for (int seed = 1; seed <= seeds; ++seed) {
        const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
        if (!reg.model.ok()) continue;
        const sim::Scene scene = FilledScan(setup, 0.60, static_cast<uint64_t>(seed), 100);
        const double true_l = scene.true_volume_m3 * kLitre;
        truth.Add(true_l);
        for (std::size_t c = 0; c < cells_cm.size(); ++c) {
            heightmap[c].Add(
                Estimate(*reg.model, scene.points, volume::Method::kHeightmap, cells_cm[c] / 100),
                true_l);
            paper_method[c].Add(
                Estimate(*reg.model, scene.points, volume::Method::kPaper, cells_cm[c] / 100),
                true_l);
        }
    }
    const double t = truth.Mean();
    std::ostringstream md;
    md << "## Table 2: grid sizes (paper bucket filled to 60 cm, " << seeds << " seeds)\n\n"
       << "True volume " << absl::StrFormat("%.1f", t) << " L (mean over seeds). Interpolated / "
       << "total cells, estimate and signed relative error, mean over seeds.\n\n"
       << "| cell (cm) | HEIGHTMAP interp./total | HEIGHTMAP (L) | err % | PAPER method "
          "interp./total "
          "| PAPER method (L) | err % | paper: empty/total \\| estimated \\| actual (10^3 cm^3) "
          "\\| err % |\n"
       << "|---|---|---|---|---|---|---|---|\n";
    double lo = 1e9, hi = -1e9;
    for (std::size_t c = 0; c < cells_cm.size(); ++c) {
        const MethodStats& h = heightmap[c];
        const MethodStats& p = paper_method[c];
        const double he = 100.0 * h.error_l.Mean() / t, pe = 100.0 * p.error_l.Mean() / t;
        lo = std::min(lo, he);
        hi = std::max(hi, he);
        md << absl::StrFormat(
            "| %.0f | %.0f/%.0f | %.1f | %+.2f | %.0f/%.0f | %.1f | %+.2f | %s |\n", cells_cm[c],
            h.cells_empty.Mean(), h.cells_total.Mean(), h.estimate_l.Mean(), he,
            p.cells_empty.Mean(), p.cells_total.Mean(), p.estimate_l.Mean(), pe, paper[c]);
        kv << absl::StrFormat(
            "table2 cell_cm=%.0f true_l=%.2f heightmap_l=%.2f heightmap_err_pct=%+.3f "
            "paper_method_l=%.2f paper_method_err_pct=%+.3f\n",
            cells_cm[c], t, h.estimate_l.Mean(), he, p.estimate_l.Mean(), pe);
    }
    md << "\nHEIGHTMAP error spread over grid sizes: " << absl::StrFormat("%.2f", hi - lo)
       << " percentage points (paper: 1.67% to 12.73%).\n\n";
    kv << absl::StrFormat("table2 heightmap_spread_pp=%.3f\n", hi - lo);
    return md.str();
}

std::string ContainerTable(int seeds, std::ostream& kv) {
    std::ostringstream md;
    md << "## Other containers (HEIGHTMAP, automatic cell size, " << seeds << " seeds)\n\n"
       << "Fill is the soil level above the lowest inner point as a share of the depth; 130% "
          "forms a heap above the rim.\n\n"
       << "| container | fill | true (L) | estimate (L) | err (L) | \\|err\\| % struck | \\|err\\| "
          "% of true | "
          "1-sigma (L) | cell (cm) |\n|---|---|---|---|---|---|---|---|---|\n";
    const std::array<double, 6> shares = {0.0, 0.25, 0.5, 0.75, 1.0, 1.3};
    for (const auto kind : {sim::ContainerKind::kPaperBucket, sim::ContainerKind::kExcavatorBucket,
                            sim::ContainerKind::kTruckBed}) {
        Setup setup;
        setup.container = kind;
        setup.sensor = PaperSensor(kind);
        const double depth = sim::MakeContainer(kind).depth_m;
        std::vector<MethodStats> rows(shares.size());
        std::vector<Stats> truth(shares.size()), cell(shares.size());
        double struck_l = 0.0;
        for (int seed = 1; seed <= seeds; ++seed) {
            const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
            struck_l = reg.true_struck_m3 * kLitre;
            if (!reg.model.ok()) {
                kv << "containers model_error=\"" << reg.model.status() << "\"\n";
                continue;
            }
            for (std::size_t s = 0; s < shares.size(); ++s) {
                const sim::Scene scene =
                    FilledScan(setup, shares[s] * depth, static_cast<uint64_t>(seed), 200 + s);
                const double true_l = scene.true_volume_m3 * kLitre;
                truth[s].Add(true_l);
                const auto e = Estimate(*reg.model, scene.points, volume::Method::kHeightmap, 0.0);
                rows[s].Add(e, true_l);
                if (e.ok()) cell[s].Add(e->volume.grid.cell_m * 100);
            }
        }
        for (std::size_t s = 0; s < shares.size(); ++s) {
            const double t = truth[s].Mean();
            const MethodStats& h = rows[s];
            md << absl::StrFormat(
                "| %s | %.0f%% | %.1f | %.1f | %+.1f | %.2f | %s | %.1f | %.1f |\n",
                ContainerName(kind), 100 * shares[s], t, h.estimate_l.Mean(), h.error_l.Mean(),
                100.0 * h.error_l.MeanAbs() / struck_l,
                t > 0.5 ? Pct(100.0 * h.error_l.MeanAbs() / t) : std::string("-"),
                h.uncertainty_l.Mean(), cell[s].Mean());
            kv << absl::StrFormat(
                "containers kind=%d fill_share=%.2f true_l=%.2f estimate_l=%.2f "
                "err_l=%+.2f abs_err_l=%.2f failures=%d\n",
                static_cast<int>(kind), shares[s], t, h.estimate_l.Mean(), h.error_l.Mean(),
                h.error_l.MeanAbs(), h.failures);
        }
    }
    md << "\n";
    return md.str();
}

std::string RobustnessTable(int seeds, std::ostream& kv) {
    struct Variant {
        const char* name;
        std::function<void(Setup&)> apply;
    };
    const std::vector<Variant> variants = {
        {"paper sensor (4 cm, 0.5 deg), 3 deg / 5 cm moves", [](Setup&) {}},
        {"precise sensor (1 cm noise)", [](Setup& s) { s.sensor.range_noise_sigma_m = 0.01; }},
        {"noisier sensor (8 cm noise)", [](Setup& s) { s.sensor.range_noise_sigma_m = 0.08; }},
        {"2% outliers", [](Setup& s) { s.sensor.outlier_fraction = 0.02; }},
        {"coarser sensor (1 deg)", [](Setup& s) { s.sensor.angular_resolution_deg = 1.0; }},
        {"closer, steeper view (2 m, 70 deg)",
         [](Setup& s) {
             s.sensor.distance_m = 2.0;
             s.sensor.elevation_deg = 70.0;
         }},
        {"corners marked with 1 cm error", [](Setup& s) { s.corner_noise_m = 0.01; }},
        {"rougher soil (5 cm perturbation)", [](Setup& s) { s.perturbation_m = 0.05; }},
        {"container moves 5 deg / 10 cm",
         [](Setup& s) {
             s.jitter = {5.0, 0.10};
         }},
    };
    std::ostringstream md;
    md << "## Robustness (paper bucket filled to 30 cm, HEIGHTMAP, automatic cell, " << seeds
       << " seeds)\n\n| variant | true (L) | estimate (L) | err (L) | \\|err\\| % of true | "
          "1-sigma (L) | "
          "failures |\n|---|---|---|---|---|---|---|\n";
    for (const Variant& v : variants) {
        Setup setup;
        setup.sensor = PaperSensor(setup.container);
        v.apply(setup);
        MethodStats h;
        Stats truth;
        for (int seed = 1; seed <= seeds; ++seed) {
            const RegisteredModel reg = RegisterEmpty(setup, static_cast<uint64_t>(seed));
            if (!reg.model.ok()) {
                ++h.failures;
                continue;
            }
            const sim::Scene scene = FilledScan(setup, 0.30, static_cast<uint64_t>(seed), 300);
            truth.Add(scene.true_volume_m3 * kLitre);
            h.Add(Estimate(*reg.model, scene.points, volume::Method::kHeightmap, 0.0),
                  scene.true_volume_m3 * kLitre);
        }
        const double t = truth.Mean();
        md << absl::StrFormat("| %s | %.1f | %.1f | %+.1f | %.2f | %.1f | %d/%d |\n", v.name, t,
                              h.estimate_l.Mean(), h.error_l.Mean(),
                              100.0 * h.error_l.MeanAbs() / t, h.uncertainty_l.Mean(), h.failures,
                              seeds);
        kv << absl::StrFormat(
            "robustness variant=\"%s\" true_l=%.2f estimate_l=%.2f err_l=%+.2f "
            "abs_err_l=%.2f failures=%d last_failure=\"%s\"\n",
            v.name, t, h.estimate_l.Mean(), h.error_l.Mean(), h.error_l.MeanAbs(), h.failures,
            h.last_failure);
    }
    md << "\n";
    return md.str();
}

namespace {

// Resident memory [KiB] from /proc/self/status ("VmRSS", "VmHWM"); 0 when unreadable.
long StatusKib(const std::string& field) {
    std::ifstream status("/proc/self/status");
    std::string line;
    while (std::getline(status, line)) {
        if (line.rfind(field + ":", 0) == 0) return std::atol(line.c_str() + field.size() + 1);
    }
    return 0;
}

// What `work` adds at its peak to the resident memory [MiB] (the kernel's high-water mark,
// reset first); negative when the kernel cannot reset it.
double PeakRssMib(const std::function<void()>& work) {
    malloc_trim(0);  // freed memory goes back to the kernel: the call's pages count again
    const long before = StatusKib("VmRSS");
    std::ofstream("/proc/self/clear_refs") << "5";
    const bool reset = StatusKib("VmHWM") <= before + 64;
    work();
    return reset ? static_cast<double>(StatusKib("VmHWM") - before) / 1024.0 : -1.0;
}

struct SpeedRow {
    std::size_t points = 0;
    Stats decode, range, outliers, align, vol, total, total_one_thread;
    double peak_mib = 0.0;
    absl::StatusOr<pipeline::VolumeEstimate> last = absl::UnknownError("not run");
    double true_l = 0.0;
};

SpeedRow TimeSize(std::size_t wanted, int repetitions) {
    SpeedRow row;
    const SizedScene sized = SceneOfAbout(wanted);
    row.points = sized.scene.points.size();
    row.true_l = sized.scene.true_volume_m3 * kLitre;
    if (!sized.reg.model.ok()) {
        row.last = sized.reg.model.status();
        return row;
    }
    const std::string ply = io::EncodePly(sized.scene.points);
    for (const int threads : {2, 1}) {
        pipeline::SetCallThreads(threads);
        for (int r = 0; r < repetitions; ++r) {
            Timer timer;
            const auto decoded = io::DecodeCloud(ply);
            const double decode_ms = timer.Lap();
            if (!decoded.ok()) {
                row.last = decoded.status();
                return row;
            }
            row.last = Estimate(*sized.reg.model, decoded->points, volume::Method::kHeightmap, 0.0);
            if (!row.last.ok()) return row;
            const pipeline::StageTimings& t = row.last->timings;
            if (threads == 1) {
                row.total_one_thread.Add(t.total_ms);
                continue;
            }
            row.decode.Add(decode_ms);
            row.range.Add(t.range_ms);
            row.outliers.Add(t.outliers_ms);
            row.align.Add(t.align_ms);
            row.vol.Add(t.volume_ms);
            row.total.Add(t.total_ms);
        }
    }
    pipeline::SetCallThreads(2);
    row.peak_mib = PeakRssMib([&] {
        const auto decoded = io::DecodeCloud(ply);
        if (decoded.ok()) {
            Estimate(*sized.reg.model, decoded->points, volume::Method::kHeightmap, 0.0)
                .IgnoreError();
        }
    });
    return row;
}

}  // namespace

std::string SpeedTable(int repetitions, std::ostream& kv) {
    std::ostringstream md;
    md << "## Speed (2 cores, median of " << repetitions << " runs)\n\n"
       << "Filled paper bucket (30 cm of soil) scanned by the paper's sensor made denser or "
          "sparser for each size; the model registered from the usual 0.5 deg empty scan. "
          "Server-side work on a decoded cloud, in the calling thread and OpenMP's (2 threads; "
          "the last time columns with 1). Peak memory: what one call adds to the process's "
          "resident set at its peak (decode included).\n\n"
       << "| points | decode PLY | range cut | outliers (SOR) | ICP + gates | grid + volume | "
          "**total** | ns/point | total, 1 thread | peak MiB | volume L (true) |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::size_t wanted :
         {std::size_t{3000}, std::size_t{20000}, std::size_t{100000}, std::size_t{1000000}}) {
        const SpeedRow row =
            TimeSize(wanted, wanted >= 1000000 ? std::max(1, repetitions / 3) : repetitions);
        if (!row.last.ok()) {
            md << "| " << row.points << " | failed: " << row.last.status().message()
               << " | | | | | | | | | |\n";
            continue;
        }
        const double total = row.total.Median();
        md << absl::StrFormat(
            "| %zu | %.2f | %.2f | %.2f | %.2f | %.2f | **%.2f** | %.0f | %.2f | %.0f | %.1f "
            "(%.1f) |\n",
            row.points, row.decode.Median(), row.range.Median(), row.outliers.Median(),
            row.align.Median(), row.vol.Median(), total,
            1e6 * total / static_cast<double>(row.points), row.total_one_thread.Median(),
            row.peak_mib, row.last->volume_m3 * kLitre, row.true_l);
        kv << absl::StrFormat(
            "speed points=%zu decode_ms=%.2f range_ms=%.2f outliers_ms=%.2f align_ms=%.2f "
            "volume_ms=%.2f total_ms=%.2f total_1thread_ms=%.2f peak_mib=%.0f icp_iterations=%d\n",
            row.points, row.decode.Median(), row.range.Median(), row.outliers.Median(),
            row.align.Median(), row.vol.Median(), total, row.total_one_thread.Median(),
            row.peak_mib, row.last->alignment.iterations);
    }
    md << "\n";
    return md.str();
}

std::string DensityTable(int seeds, std::ostream& kv) {
    std::ostringstream md;
    md << "## Scan density (paper bucket, 30 cm of soil, " << seeds << " seeds)\n\n"
       << "The speed table's scenes: the paper's sensor made denser or sparser, the model from "
          "the usual 0.5 deg empty scan. Error = estimate - truth.\n\n"
       << "| points | cell | cell m (median) | mean error L | max abs error L | max abs, % "
          "struck | 2-sigma | pose z error mm (mean) | pose turn deg (mean) | failures |\n"
       << "|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::size_t wanted :
         {std::size_t{20000}, std::size_t{100000}, std::size_t{300000}, std::size_t{1000000}}) {
        std::vector<SizedScene> scenes;
        for (int seed = 1; seed <= seeds; ++seed) {
            scenes.push_back(SceneOfAbout(wanted, static_cast<uint64_t>(seed)));
        }
        for (const double cell : {0.0, 0.10}) {
            Stats error, cells, struck, pose_dz_mm, pose_deg;
            int covered = 0, failures = 0;
            std::size_t points = 0;
            for (const SizedScene& s : scenes) {
                points = s.scene.points.size();
                if (!s.reg.model.ok()) {
                    ++failures;
                    continue;
                }
                const auto e =
                    Estimate(*s.reg.model, s.scene.points, volume::Method::kHeightmap, cell);
                if (!e.ok()) {
                    ++failures;
                    continue;
                }
                const double err = (e->volume_m3 - s.scene.true_volume_m3) * kLitre;
                error.Add(err);
                cells.Add(e->volume.grid.cell_m);
                struck.Add(s.reg.model->struck_capacity_m3 * kLitre);
                if (std::abs(err) <= 2.0 * e->uncertainty_m3 * kLitre) ++covered;
                // The found pose against the truth, in the container frame.
                const Pose delta = (s.scene.T_scan_container * s.reg.sim_to_model).inverse() *
                                   e->alignment.T_scan_container;
                pose_dz_mm.Add(1000.0 * delta.translation().z());
                pose_deg.Add(Eigen::AngleAxisd(delta.linear()).angle() * 180.0 / 3.14159265358979);
                kv << absl::StrFormat(
                    "density points=%zu seed_cell=%.2f cell_m=%.4f error_l=%.2f sigma_l=%.2f\n",
                    points, cell, e->volume.grid.cell_m, err, e->uncertainty_m3 * kLitre);
            }
            const double max_abs = error.MaxAbs();
            md << absl::StrFormat(
                "| %zu | %s | %.3f | %+.1f | %.1f | %.2f | %d/%zu | %+.1f | %.2f | %d/%d |\n",
                points, cell > 0.0 ? "10 cm" : "automatic", cells.Median(), error.Mean(), max_abs,
                struck.Median() > 0.0 ? 100.0 * max_abs / struck.Median() : 0.0, covered,
                error.values.size(), pose_dz_mm.Mean(), pose_deg.Mean(), failures, seeds);
        }
    }
    md << "\n";
    return md.str();
}

}  // namespace soilvol::bench
