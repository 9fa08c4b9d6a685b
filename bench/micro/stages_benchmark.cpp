// Per-stage micro-benchmarks of the cloud estimator (Google Benchmark), on the speed table's
// scenes: a filled paper bucket scanned at 3k, 20k, 100k and 1M points. Each stage runs on the
// previous stage's real output, with 1 and 2 threads. Run: build/bench/soilvol-microbench
// (--benchmark_filter=Align, --benchmark_repetitions=5, ...).
#include <benchmark/benchmark.h>

#include <cstddef>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <string_view>

#include "bench/trial.hpp"
#include "core/cloud/angular_sampling.hpp"
#include "core/cloud/outlier_filter.hpp"
#include "core/cloud/preprocess.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/allocator.hpp"
#include "core/common/build_info.hpp"
#include "core/io/cloud_codec.hpp"
#include "core/model/container_model.hpp"
#include "core/pipeline/estimator.hpp"
#include "core/pipeline/parallelism.hpp"

namespace soilvol::bench {
namespace {

// One scene per size with every stage's input, made once.
struct Stages {
    SizedScene sized;
    std::string ply;
    cloud::PreprocessResult pre;
    std::vector<SensorCloud> sensors;  ///< `pre` as the scan's one sensor
    pipeline::ScanAlignment aligned;
    Cloud in_container;
};

const Stages& StagesFor(std::size_t points) {
    static std::map<std::size_t, std::unique_ptr<Stages>> made;
    std::unique_ptr<Stages>& slot = made[points];
    if (slot) return *slot;
    slot = std::make_unique<Stages>();
    Stages& s = *slot;
    s.sized = SceneOfAbout(points);
    if (!s.sized.reg.model.ok()) return s;
    const pipeline::EstimateConfig config;
    s.ply = io::EncodePly(s.sized.scene.points);
    s.pre = cloud::Preprocess(s.sized.scene.points, config.preprocess);
    s.sensors = {SensorCloud{s.pre.points, Pose::Identity()}};
    const auto aligned = pipeline::AlignScan(*s.sized.reg.model, s.pre.points, s.sensors, config);
    if (aligned.ok()) {
        s.aligned = *aligned;
        s.in_container = model::ToContainerFrame(s.pre.points, aligned->alignment.T_scan_container);
    }
    return s;
}

// state.range(0): points; state.range(1): threads.
const Stages* Prepare(benchmark::State& state) {
    pipeline::SetCallThreads(static_cast<int>(state.range(1)));
    const Stages& s = StagesFor(static_cast<std::size_t>(state.range(0)));
    if (!s.sized.reg.model.ok() || s.in_container.empty()) {
        state.SkipWithError("the scene did not register or align");
        return nullptr;
    }
    state.counters["points"] = static_cast<double>(s.sized.scene.points.size());
    state.counters["kept"] = static_cast<double>(s.pre.points.size());
    state.counters["model_pts"] = static_cast<double>(s.sized.reg.model->alignment_points.size());
    state.counters["icp_target"] = static_cast<double>(s.aligned.alignment.target_points);
    state.counters["icp_iters"] = s.aligned.alignment.iterations;
    return &s;
}

void Report(benchmark::State& state, std::size_t points) {
    state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(points));
}

void BM_DecodePly(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    for (auto _ : state) benchmark::DoNotOptimize(io::DecodeCloud(s->ply));
    Report(state, s->sized.scene.points.size());
}

void BM_VoxelGrid(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    for (auto _ : state) benchmark::DoNotOptimize(cloud::VoxelGrid(s->sized.scene.points, 0.02));
    Report(state, s->sized.scene.points.size());
}

// What registration adds to find a spinning lidar's rows (once per empty scan and sensor).
void BM_AngularSampling(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            cloud::MeasureAngularSampling(s->pre.points, Eigen::Vector3d::Zero()));
    }
    Report(state, s->pre.points.size());
}

void BM_Preprocess(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    const pipeline::EstimateConfig config;
    for (auto _ : state) {
        benchmark::DoNotOptimize(cloud::Preprocess(s->sized.scene.points, config.preprocess));
    }
    Report(state, s->sized.scene.points.size());
}

void BM_Align(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    const pipeline::EstimateConfig config;
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            pipeline::AlignScan(*s->sized.reg.model, s->pre.points, s->sensors, config));
    }
    Report(state, s->pre.points.size());
}

void BM_Volume(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    const pipeline::EstimateConfig config;
    for (auto _ : state) {
        benchmark::DoNotOptimize(pipeline::IntegrateVolume(
            *s->sized.reg.model, s->in_container, s->aligned.alignment.T_scan_container, config));
    }
    Report(state, s->in_container.size());
}

void BM_Estimate(benchmark::State& state) {
    const Stages* s = Prepare(state);
    if (s == nullptr) return;
    const pipeline::EstimateConfig config;
    for (auto _ : state) {
        benchmark::DoNotOptimize(
            pipeline::EstimateVolume(*s->sized.reg.model, s->sized.scene.points, config));
    }
    Report(state, s->sized.scene.points.size());
}

void Sizes(benchmark::internal::Benchmark* b) {
    for (const int threads : {1, 2}) {
        for (const int points : {3000, 20000, 100000, 1000000}) b->Args({points, threads});
    }
    b->ArgNames({"points", "threads"})->Unit(benchmark::kMillisecond)->UseRealTime();
}

BENCHMARK(BM_DecodePly)->Apply(Sizes);
BENCHMARK(BM_VoxelGrid)->Apply(Sizes);
BENCHMARK(BM_AngularSampling)->Apply(Sizes);
BENCHMARK(BM_Preprocess)->Apply(Sizes);
BENCHMARK(BM_Align)->Apply(Sizes);
BENCHMARK(BM_Volume)->Apply(Sizes);
BENCHMARK(BM_Estimate)->Apply(Sizes);

}  // namespace
}  // namespace soilvol::bench

int main(int argc, char** argv) {
    soilvol::KeepFreedMemoryForReuse();  // as soilvol-server does
    if (argc == 2 && std::string_view(argv[1]) == "--version") {
        std::cout << soilvol::VersionLine("soilvol-microbench") << "\n";
        return 0;
    }
    benchmark::Initialize(&argc, argv);
    if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
    benchmark::RunSpecifiedBenchmarks();
    benchmark::Shutdown();
    return 0;
}
