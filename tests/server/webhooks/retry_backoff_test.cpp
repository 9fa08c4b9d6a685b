#include "server/webhooks/retry_backoff.hpp"

#include <gtest/gtest.h>

#include <climits>
#include <cmath>
#include <limits>
#include <random>

namespace soilvol::server {
namespace {

using std::chrono::milliseconds;

TEST(RetryBackoff, DelaysDoubleWithinHalfAndWholeOfTheirCeiling) {
    const RetryBackoff backoff;  // 1 s, capped at 5 min
    std::mt19937 random(7);
    std::uniform_real_distribution<double> uniform(0.0, 1.0);
    for (int attempt = 1; attempt <= 12; ++attempt) {
        const std::int64_t ceiling = std::min<std::int64_t>(1000LL << (attempt - 1), 300000);
        for (int draw = 0; draw < 200; ++draw) {
            const milliseconds delay = RetryDelay(backoff, attempt, uniform(random));
            ASSERT_GE(delay.count(), ceiling / 2) << "attempt " << attempt;
            ASSERT_LT(delay.count(), ceiling) << "attempt " << attempt;
        }
        EXPECT_EQ(RetryDelay(backoff, attempt, 0.0).count(), ceiling / 2);
        EXPECT_NEAR(RetryDelay(backoff, attempt, 0.5).count(), 0.75 * ceiling, 1.0);
        EXPECT_GE(RetryDelay(backoff, attempt, 0.999999).count(), ceiling - 1);
    }
}

TEST(RetryBackoff, TheCapHoldsForAnyAttempt) {
    const RetryBackoff backoff{milliseconds(1000), milliseconds(300000)};
    EXPECT_EQ(RetryDelay(backoff, 9, 0.0), milliseconds(128000));
    EXPECT_EQ(RetryDelay(backoff, 10, 0.0), milliseconds(150000)) << "512 s capped to 300 s";
    for (int attempt : {10, 11, 62, 63, 64, 65, 1000, INT_MAX}) {
        EXPECT_EQ(RetryDelay(backoff, attempt, 0.0), milliseconds(150000)) << attempt;
        EXPECT_EQ(RetryDelay(backoff, attempt, 1.0), milliseconds(299999)) << attempt;
    }
}

TEST(RetryBackoff, HugeDurationsDoNotOverflow) {
    constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
    const RetryBackoff backoff{milliseconds(kMax / 3), milliseconds(kMax)};
    EXPECT_EQ(RetryDelay(backoff, 1, 0.0).count(), kMax / 3 / 2);
    EXPECT_EQ(RetryDelay(backoff, INT_MAX, 0.0).count(), kMax / 2);
    const std::int64_t top = RetryDelay(backoff, INT_MAX, 1.0).count();
    EXPECT_GT(top, kMax / 2);
    EXPECT_LT(top, kMax);
    const RetryBackoff tiny_cap{milliseconds(1000), milliseconds(1)};
    EXPECT_EQ(RetryDelay(tiny_cap, 1, 0.9), milliseconds(0)) << "a ceiling of 1 ms: [0, 1)";
}

TEST(RetryBackoff, OutOfRangeInputsAreClamped) {
    const RetryBackoff backoff;
    EXPECT_EQ(RetryDelay(backoff, 0, 0.0), milliseconds(500)) << "attempt 0 counts as 1";
    EXPECT_EQ(RetryDelay(backoff, INT_MIN, 0.0), milliseconds(500));
    EXPECT_EQ(RetryDelay(backoff, 1, -3.0), milliseconds(500));
    EXPECT_EQ(RetryDelay(backoff, 1, 7.0), milliseconds(999));
    EXPECT_EQ(RetryDelay(backoff, 1, std::nan("")), milliseconds(500));
    EXPECT_EQ(RetryDelay(backoff, 1, std::numeric_limits<double>::infinity()), milliseconds(999));
    const RetryBackoff negative{milliseconds(-1000), milliseconds(-5)};
    EXPECT_EQ(RetryDelay(negative, 3, 0.5), milliseconds(0));
    const RetryBackoff zero_base{milliseconds(0), milliseconds(300000)};
    EXPECT_EQ(RetryDelay(zero_base, 40, 0.9), milliseconds(0));
}

}  // namespace
}  // namespace soilvol::server
