#include "core/model/model_cache.hpp"

#include <gtest/gtest.h>

#include <random>

#include "core/sim/scene.hpp"

namespace soilvol::model {
namespace {

ContainerModel PaperBucketModel() {
    sim::SceneSpec spec;
    spec.container = sim::ContainerKind::kPaperBucket;
    spec.sensor.range_noise_sigma_m = 0.02;
    spec.sensor.elevation_deg = 55.0;
    spec.sensor.azimuth_deg = 30.0;
    spec.scan_seed = 5;
    const sim::Scene scan = sim::SimulateScene(spec);
    auto model = BuildContainerModel(scan.points, scan.opening_corners_scan, ModelConfig{});
    EXPECT_TRUE(model.ok()) << model.status();
    return *std::move(model);
}

// The rule StructureIndex answers, point by point and without its shortcuts.
bool NearByDefinition(const ContainerModel& model, const Eigen::Vector3f& p) {
    const double r = model.structure_radius_m;
    double best = 1e300;
    for (const auto& s : model.structure) best = std::min(best, (s - p).cast<double>().norm());
    return best <= r;
}

TEST(StructureIndexTest, AnswersAsTheNearestStructurePointDoesEverywhere) {
    const ContainerModel model = PaperBucketModel();
    ASSERT_FALSE(model.structure.empty());
    ASSERT_GT(model.structure_radius_m, 0.0);
    const StructureIndex index(model);
    // Points over the whole column and around it, most near the rim where the shortcuts end.
    const Eigen::Vector2d lo = model.opening.polygon.Min(), hi = model.opening.polygon.Max();
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> ux(lo.x() - 0.2, hi.x() + 0.2);
    std::uniform_real_distribution<double> uy(lo.y() - 0.2, hi.y() + 0.2);
    std::uniform_real_distribution<double> uz(-0.7, 0.2);
    int near = 0;
    for (int i = 0; i < 4000; ++i) {
        const Eigen::Vector3f p(static_cast<float>(ux(rng)), static_cast<float>(uy(rng)),
                                static_cast<float>(uz(rng)));
        const bool expected = NearByDefinition(model, p);
        near += expected ? 1 : 0;
        ASSERT_EQ(index.Near(p), expected) << p.transpose();
    }
    // The sample met the structure, and mostly missed it.
    EXPECT_GT(near, 100);
    EXPECT_LT(near, 3000);
    // The structure's own points are near it.
    for (std::size_t i = 0; i < model.structure.size(); i += 17) {
        EXPECT_TRUE(index.Near(model.structure[i]));
    }
}

TEST(ModelCacheTest, EmptySurfaceIsComputedOncePerGridAndMatchesADirectComputation) {
    const ContainerModel model = PaperBucketModel();
    ASSERT_TRUE(model.cache);
    const volume::HeightmapConfig config;
    const volume::Grid grid = volume::MakeGrid(model.opening.polygon, 0.05);
    const auto first = model.cache->EmptySurface(model, grid, config);
    ASSERT_TRUE(first.ok()) << first.status();
    const auto again = model.cache->EmptySurface(model, grid, config);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(first->get(), again->get());
    const auto direct = volume::EstimateEmptySurface(grid, model.cavity, config);
    ASSERT_TRUE(direct.ok());
    ASSERT_EQ((*first)->map.height.size(), direct->map.height.size());
    for (std::size_t k = 0; k < direct->map.height.size(); ++k) {
        if (std::isnan(direct->map.height[k])) continue;
        EXPECT_DOUBLE_EQ((*first)->map.height[k], direct->map.height[k]);
        EXPECT_DOUBLE_EQ((*first)->unobserved_sigma_m[k], direct->unobserved_sigma_m[k]);
    }
    // Another surface configuration is another entry.
    volume::HeightmapConfig other = config;
    other.surface.tukey_sigmas = 3.0;
    const auto changed = model.cache->EmptySurface(model, grid, other);
    ASSERT_TRUE(changed.ok());
    EXPECT_NE(changed->get(), first->get());
}

TEST(ModelCacheTest, KeepsTheLastFewGridsOnly) {
    const ContainerModel model = PaperBucketModel();
    const volume::HeightmapConfig config;
    const volume::Grid first_grid = volume::MakeGrid(model.opening.polygon, 0.05);
    const auto first = model.cache->EmptySurface(model, first_grid, config);
    ASSERT_TRUE(first.ok());
    const std::weak_ptr<const volume::EmptySurface> watch = *first;
    for (std::size_t i = 1; i <= ModelCache::kMaxSurfaces; ++i) {
        const volume::Grid grid =
            volume::MakeGrid(model.opening.polygon, 0.05 + 0.01 * static_cast<double>(i));
        ASSERT_TRUE(model.cache->EmptySurface(model, grid, config).ok());
    }
    // The oldest entry went; only the caller's reference keeps it.
    const auto recomputed = model.cache->EmptySurface(model, first_grid, config);
    ASSERT_TRUE(recomputed.ok());
    EXPECT_NE(recomputed->get(), first->get());
    EXPECT_FALSE(watch.expired());
}

TEST(ModelCacheTest, AChangedModelGetsANewCache) {
    sim::SceneSpec spec;
    spec.container = sim::ContainerKind::kPaperBucket;
    spec.sensor.range_noise_sigma_m = 0.01;
    spec.sensor.azimuth_deg = 30.0;
    const sim::Scene first = sim::SimulateScene(spec);
    auto model = BuildContainerModel(first.points, first.opening_corners_scan, ModelConfig{});
    ASSERT_TRUE(model.ok()) << model.status();
    const std::shared_ptr<ModelCache> before = model->cache;
    spec.scan_seed = 9;  // the container where it was, scanned again
    const sim::Scene second = sim::SimulateScene(spec);
    const absl::Status added =
        AddEmptyScan(second.points, model->opening.T_scan_container, ModelConfig{}, *model);
    ASSERT_TRUE(added.ok()) << added.ToString();
    EXPECT_NE(model->cache, before);
}

}  // namespace
}  // namespace soilvol::model
