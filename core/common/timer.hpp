#pragma once

#include <chrono>

namespace soilvol {

/// Wall-clock stopwatch for per-stage timings [ms].
class Timer {
  public:
    Timer() : start_(std::chrono::steady_clock::now()) {}
    /// Milliseconds since construction or the last Lap(), and restarts.
    double Lap() {
        const auto now = std::chrono::steady_clock::now();
        const double ms = std::chrono::duration<double, std::milli>(now - start_).count();
        start_ = now;
        return ms;
    }

  private:
    std::chrono::steady_clock::time_point start_;
};

}  // namespace soilvol
