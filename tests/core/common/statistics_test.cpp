#include "core/common/statistics.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace soilvol {
namespace {

TEST(StatisticsTest, QuantileIsTheNearestRankBelow) {
    const std::vector<int> v = {5, 1, 4, 2, 3};
    EXPECT_EQ(Quantile(v, 0.0), 1.0);
    EXPECT_EQ(Quantile(v, 0.5), 3.0);
    EXPECT_EQ(Quantile(v, 0.74), 3.0);  // rank floor(0.74 * 4) = 2
    EXPECT_EQ(Quantile(v, 0.75), 4.0);
    EXPECT_EQ(Quantile(v, 1.0), 5.0);
    EXPECT_EQ(Quantile(v, 7.0), 5.0);  // clamped
    EXPECT_TRUE(std::isnan(Quantile(std::vector<int>{}, 0.5)));
}

TEST(StatisticsTest, MedianIsTheUpperMiddle) {
    EXPECT_EQ(Median(std::vector<double>{4.0, 1.0, 3.0, 2.0}), 3.0);
    EXPECT_EQ(Median(std::vector<double>{2.0, 9.0, 1.0}), 2.0);
    EXPECT_TRUE(std::isnan(Median(std::vector<double>{})));
}

TEST(StatisticsTest, RobustSigmaIgnoresAnOutlier) {
    // |v - 0| = 1 for all but one: MAD 1, sigma 1.4826 whatever the outlier is.
    const std::vector<double> v = {-1.0, 1.0, -1.0, 1.0, 1000.0};
    EXPECT_DOUBLE_EQ(RobustSigma(v, 0.0), 1.4826);
}

TEST(StatisticsTest, WeightedMeanSdCountsEachValueItsWeightTimes) {
    // {1 x2, 4 x1} is the sample {1, 1, 4}: mean 2, sd sqrt((1 + 1 + 4) / 2).
    const std::vector<float> v = {1.0f, 4.0f};
    const std::vector<int> w = {2, 1};
    const MeanSd s = WeightedMeanSd(v, [&](std::size_t i) { return static_cast<double>(w[i]); });
    EXPECT_DOUBLE_EQ(s.mean, 2.0);
    EXPECT_DOUBLE_EQ(s.sd, std::sqrt(3.0));
    const MeanSd unit =
        WeightedMeanSd(std::vector<double>{1.0, 1.0, 4.0}, [](std::size_t) { return 1.0; });
    EXPECT_DOUBLE_EQ(unit.mean, s.mean);
    EXPECT_DOUBLE_EQ(unit.sd, s.sd);
}

TEST(StatisticsTest, WeightedMeanSdOfNothingIsNaN) {
    EXPECT_TRUE(
        std::isnan(WeightedMeanSd(std::vector<double>{}, [](std::size_t) { return 1.0; }).mean));
    const MeanSd one = WeightedMeanSd(std::vector<double>{3.0}, [](std::size_t) { return 1.0; });
    EXPECT_DOUBLE_EQ(one.mean, 3.0);
    EXPECT_DOUBLE_EQ(one.sd, 0.0);
}

}  // namespace
}  // namespace soilvol
