#include "server/webhooks/retry_backoff.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace soilvol::server {
namespace {

// min(cap, base * 2^doublings), without forming a product past the cap.
std::int64_t CappedDoubling(std::int64_t base, std::int64_t cap, int doublings) {
    if (base == 0) return 0;
    std::int64_t delay = base;
    for (int i = 0; i < doublings && delay < cap; ++i) {
        delay = delay > cap / 2 ? cap : delay * 2;
    }
    return std::min(delay, cap);
}

}  // namespace

std::chrono::milliseconds RetryDelay(const RetryBackoff& backoff, int attempt, double uniform01) {
    const std::int64_t base = std::max<std::int64_t>(backoff.base.count(), 0);
    const std::int64_t cap = std::max<std::int64_t>(backoff.cap.count(), 0);
    // The loop stops at the cap: at most 63 doublings whatever the attempt.
    const std::int64_t ceiling = CappedDoubling(base, cap, std::max(attempt, 1) - 1);
    const double u =
        std::isnan(uniform01) ? 0.0 : std::clamp(uniform01, 0.0, std::nextafter(1.0, 0.0));
    // Equal jitter: half fixed, half uniform; the uniform half stays below its width.
    const std::int64_t half = ceiling / 2;
    const std::int64_t width = ceiling - half;
    std::int64_t jitter = static_cast<std::int64_t>(u * static_cast<double>(width));
    jitter = std::clamp<std::int64_t>(jitter, 0, std::max<std::int64_t>(width - 1, 0));
    return std::chrono::milliseconds(half + jitter);
}

}  // namespace soilvol::server
