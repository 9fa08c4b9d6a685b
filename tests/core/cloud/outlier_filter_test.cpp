#include "core/cloud/outlier_filter.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/cloud/preprocess.hpp"

namespace soilvol::cloud {
namespace {

// A noisy 1 m x 1 m plane at 2.5 m plus isolated outliers spread through a 3 m cube.
Cloud NoisyPlane(std::size_t n, std::size_t outliers, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-0.5f, 0.5f);
    std::normal_distribution<float> noise(0.0f, 0.01f);
    Cloud cloud;
    // One draw per statement: the order of a call's arguments is the compiler's (GCC and clang
    // differ), the cloud must not be.
    for (std::size_t i = 0; i < n; ++i) {
        const float x = u(rng);
        const float y = u(rng);
        cloud.emplace_back(x, y, 2.5f + noise(rng));
    }
    std::uniform_real_distribution<float> far(-1.5f, 1.5f);
    for (std::size_t i = 0; i < outliers; ++i) {
        const float x = far(rng);
        const float y = far(rng);
        cloud.emplace_back(x, y, 2.5f + far(rng));
    }
    return cloud;
}

double BruteForceMean(const Cloud& cloud, std::size_t i, int k) {
    std::vector<double> d;
    for (std::size_t j = 0; j < cloud.size(); ++j) {
        if (j != i) d.push_back(static_cast<double>((cloud[j] - cloud[i]).norm()));
    }
    std::partial_sort(d.begin(), d.begin() + k, d.end());
    double sum = 0.0;
    for (int j = 0; j < k; ++j) sum += d[static_cast<std::size_t>(j)];
    return sum / k;
}

// Exact where the k nearest lie within the searched blocks, a lower bound elsewhere. On this
// surface (density rho) the blocks reach 2h with pi h^2 rho = 1.44 k, so a point has fewer than
// k neighbours there with the Poisson probability P(N < k; 5.76 k): 0.3% for k = 1, below 1e-9
// for k = 8. The test allows 2% inexact at k = 1 (an 8-sigma margin over 430 points) and none
// beyond.
TEST(OutlierFilterTest, MeanNeighborDistancesAreExactOnTheSurface) {
    const Cloud cloud = NoisyPlane(3000, 60, 7);
    for (const int k : {1, 8, 16}) {
        const std::vector<float> mean = MeanNeighborDistances(cloud, k, 2);
        int sampled = 0, inexact = 0;
        for (std::size_t i = 0; i < 3000; i += 7) {
            const double exact = BruteForceMean(cloud, i, k);
            EXPECT_LE(static_cast<double>(mean[i]), exact + 1e-5) << "point " << i << " k " << k;
            ++sampled;
            inexact += std::abs(static_cast<double>(mean[i]) - exact) >= 1e-5;
        }
        EXPECT_LE(inexact, k == 1 ? sampled / 50 : 0) << "k " << k;
        // Isolated outliers get a lower bound, at least 2h: in theory 2.9x the surface's median
        // at k = 1 and more beyond, 2.0x measured at k = 1 (the voxel count reads this noisy
        // surface's density high, so h comes out smaller). Asked: 1.5x.
        std::vector<float> surface(mean.begin(), mean.begin() + 3000);
        std::nth_element(surface.begin(), surface.begin() + 1500, surface.end());
        const float surface_median = surface[1500];
        for (std::size_t i = 3000; i < cloud.size(); ++i) {
            const double exact = BruteForceMean(cloud, i, k);
            EXPECT_LE(static_cast<double>(mean[i]), exact + 1e-5) << "outlier " << i;
            EXPECT_TRUE(std::abs(static_cast<double>(mean[i]) - exact) < 1e-5 ||
                        mean[i] > 1.5f * surface_median)
                << "outlier " << i << " k " << k;
        }
    }
}

TEST(OutlierFilterTest, IsolatedReturnsAreRemovedAndTheSurfaceKept) {
    const Cloud cloud = NoisyPlane(20000, 200, 3);
    const OutlierFilterResult result = RemoveStatisticalOutliers(cloud, OutlierFilterConfig{});
    std::size_t outliers_left = 0;
    for (const auto& p : result.kept) {
        if (std::abs(p.z() - 2.5f) > 0.06f || std::abs(p.x()) > 0.5f || std::abs(p.y()) > 0.5f) {
            ++outliers_left;
        }
    }
    EXPECT_LE(outliers_left, 4u);           // outliers that happen to land on the plane stay
    EXPECT_GE(result.kept.size(), 19000u);  // at most 5% of the surface goes
}

TEST(OutlierFilterTest, TinyCloudsPassThrough) {
    const Cloud cloud = NoisyPlane(10, 0, 1);
    EXPECT_EQ(RemoveStatisticalOutliers(cloud, OutlierFilterConfig{}).kept.size(), 10u);
    EXPECT_TRUE(RemoveStatisticalOutliers(Cloud{}, OutlierFilterConfig{}).kept.empty());
}

TEST(OutlierFilterTest, DuplicatePointsDoNotBreakTheGrid) {
    Cloud cloud(500, Eigen::Vector3f(1.0f, 2.0f, 3.0f));
    const std::vector<float> mean = MeanNeighborDistances(cloud, 8, 1);
    for (const float m : mean) EXPECT_EQ(m, 0.0f);
}

TEST(PreprocessTest, RangeCutDropsBackground) {
    Cloud cloud = NoisyPlane(2000, 0, 5);
    cloud.emplace_back(0.0f, 0.0f, 9.0f);
    cloud.emplace_back(0.0f, 0.0f, 0.1f);
    PreprocessConfig config;
    config.max_range_m = 4.0;
    config.min_range_m = 0.5;
    config.remove_outliers = false;
    const PreprocessResult result = Preprocess(cloud, config);
    EXPECT_EQ(result.after_range, 2000u);
    EXPECT_EQ(result.points.size(), 2000u);
}

}  // namespace
}  // namespace soilvol::cloud
