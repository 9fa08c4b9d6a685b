#include "core/cloud/local_surface.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/cloud/voxel_grid.hpp"

namespace soilvol::cloud {
namespace {

// A noisy horizontal plate: the means lie on it far closer than the noise, the normals are
// vertical.
TEST(LocalSurfaceTest, MeansOfAPlateLieOnItWithVerticalNormals) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> xy(0.0f, 1.0f);
    std::normal_distribution<float> noise(0.0f, 0.01f);
    Cloud points;
    for (int i = 0; i < 20000; ++i) points.push_back({xy(rng), xy(rng), 0.5f + noise(rng)});
    const LocalSurface s = SmoothLocalSurface(points, 0.05);
    ASSERT_EQ(s.points.size(), points.size());
    ASSERT_EQ(s.sources.size(), points.size());
    // About 150 neighbours inside: a mean scatters by 0.01 / sqrt(150) ~ 0.8 mm, plus the pull
    // of a ball centred off the plate towards its centre (a 3-sigma source: ~5 mm).
    // Normals, away from the plate's edges (half neighbourhoods): each tilts by the noise's
    // correlation with the spread, ~ (0.01 / 0.025) / sqrt(150) rad ~ 2 deg on average.
    double off = 0.0, source_off = 0.0, worst = 0.0, tilt = 0.0;
    int interior = 0;
    for (std::size_t i = 0; i < s.points.size(); ++i) {
        const Eigen::Vector2f at = s.sources[i].head<2>();
        if ((at.array() < 0.1f).any() || (at.array() > 0.9f).any()) continue;
        const double dz = std::abs(static_cast<double>(s.points[i].z()) - 0.5);
        off += dz;
        worst = std::max(worst, dz);
        source_off += std::abs(static_cast<double>(s.sources[i].z()) - 0.5);
        tilt += std::acos(std::min(1.0, std::abs(static_cast<double>(s.normals[i].z()))));
        ++interior;
    }
    ASSERT_GT(interior, 10000);
    EXPECT_LT(off / interior, 0.25 * source_off / interior);
    EXPECT_LT(worst, 0.012);
    EXPECT_LT(tilt / interior * 180.0 / 3.14159265358979, 4.0);
}

TEST(LocalSurfaceTest, IsolatedPointsAreDropped) {
    const Cloud points = {{0.0f, 0.0f, 0.0f}, {0.01f, 0.0f, 0.0f}, {5.0f, 5.0f, 5.0f}};
    EXPECT_TRUE(SmoothLocalSurface(points, 0.1, 3).points.empty());
    EXPECT_EQ(SmoothLocalSurface(points, 0.1, 2).points.size(), 2u);
}

// A weight is that many copies of the point: the means and normals agree with the copies'.
TEST(LocalSurfaceTest, WeightsActAsCopies) {
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 0.3f);
    std::uniform_int_distribution<int> copies(1, 4);
    Cloud points, copied;
    std::vector<float> weights;
    for (int i = 0; i < 400; ++i) {
        const Eigen::Vector3f p(u(rng), u(rng), 0.2f * u(rng) * u(rng));
        const int w = copies(rng);
        points.push_back(p);
        weights.push_back(static_cast<float>(w));
        for (int c = 0; c < w; ++c) copied.push_back(p);
    }
    const LocalSurface weighted = SmoothLocalSurface(points, weights, 0.08, 1);
    ASSERT_EQ(weighted.points.size(), points.size());
    const LocalSurface repeated = SmoothLocalSurface(copied, 0.08, 1);
    std::size_t j = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        EXPECT_LT((weighted.points[i] - repeated.points[j]).norm(), 1e-5f);
        EXPECT_GT(std::abs(weighted.normals[i].dot(repeated.normals[j])), 0.9999f);
        j += static_cast<std::size_t>(weights[i]);
    }
}

// A roof ridge (two planes meeting at 90 degrees) with range noise, sampled sparse and 50 times
// denser. Smoothing voxel centroids weighted by their counts gives, near the ridge, the means
// the raw sparse returns give; unweighted centroids of the dense scan weigh its noise tails
// like the surface and sit elsewhere (the density drift ICP had).
// Mean height of the means near the ridge, each weighing what its source stands for.
double RidgeHeight(const LocalSurface& s, const VoxelCentroids* voxels = nullptr) {
    double sum = 0.0, n = 0.0;
    for (std::size_t i = 0; i < s.points.size(); ++i) {
        if (std::abs(s.sources[i].x()) > 0.03f || std::abs(s.sources[i].y()) > 0.3f) continue;
        double w = 1.0;
        if (voxels != nullptr) {
            // The sources are the centroids themselves, in order with gaps: find by position.
            const auto it = std::find(voxels->points.begin(), voxels->points.end(), s.sources[i]);
            w = static_cast<double>(
                voxels
                    ->counts[static_cast<std::size_t>(std::distance(voxels->points.begin(), it))]);
        }
        sum += w * static_cast<double>(s.points[i].z());
        n += w;
    }
    return n > 0.0 ? sum / n : 1e9;
}

Cloud Ridge(int count, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> along(-0.5f, 0.5f), across(-0.4f, 0.4f);
    std::normal_distribution<float> noise(0.0f, 0.03f);
    Cloud points;
    for (int i = 0; i < count; ++i) {
        const float x = across(rng);
        // Noise along a vertical ray, as a sensor above sees the ridge.
        points.push_back({x, along(rng), -std::abs(x) + noise(rng)});
    }
    return points;
}

TEST(LocalSurfaceTest, CountWeightedCentroidsGiveTheSameMeansAtAnyDensity) {
    constexpr double kRadius = 0.12;
    const Cloud sparse = Ridge(4000, 11);
    const Cloud dense = Ridge(200000, 12);
    const LocalSurface raw = SmoothLocalSurface(sparse, kRadius);
    const double reference = RidgeHeight(raw);
    const VoxelCentroids voxels = CentroidsOf(dense, 0.03);
    const LocalSurface weighted = SmoothLocalSurface(voxels.points, voxels.counts, kRadius);
    const LocalSurface unweighted = SmoothLocalSurface(voxels.points, kRadius);
    const double with_counts = RidgeHeight(weighted, &voxels);
    const double without = RidgeHeight(unweighted, &voxels);
    std::printf("ridge: sparse raw %.4f, dense weighted %.4f, unweighted %.4f\n", reference,
                with_counts, without);
    // The smoothing rounds the ridge off by ~37 mm; unweighted dense centroids by ~11 mm less.
    EXPECT_NEAR(with_counts, reference, 0.003);
    EXPECT_GT(std::abs(without - reference), 0.006);
}

}  // namespace
}  // namespace soilvol::cloud
