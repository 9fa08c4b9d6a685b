#pragma once

#include <chrono>

namespace soilvol::server {

/// Exponential backoff between a webhook's attempts.
struct RetryBackoff {
    std::chrono::milliseconds base{1000};   ///< the delay's ceiling after the first failure
    std::chrono::milliseconds cap{300000};  ///< the largest ceiling
};

/// The delay before the next attempt after `attempt` failures (1 = after the first), with
/// "equal jitter": d = min(cap, base * 2^(attempt - 1)), then d/2 + uniform01 * d/2, so within
/// [d/2, d) [ms] (0 when d is 0). `uniform01` is clamped into [0, 1) (NaN counts as 0), an attempt
/// below 1 counts as 1, negative durations as 0; no overflow for any attempt.
std::chrono::milliseconds RetryDelay(const RetryBackoff& backoff, int attempt, double uniform01);

}  // namespace soilvol::server
