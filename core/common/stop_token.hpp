#pragma once

#include <atomic>
#include <chrono>
#include <functional>
#include <memory>
#include <string_view>

#include "absl/status/status.h"

namespace soilvol {

/// Whether one call's work should stop early: its deadline passed or its caller went away.
/// Checked between the stages of a pipeline and inside long loops. A default token never stops.
/// Thread-safe (checked from OpenMP threads); `cancelled` must be thread-safe and cheap. Once a
/// token has stopped it stays stopped (copies share that), so work that returned early on a stop
/// and the stage check after it agree; `cancelled` is not called again then.
class StopToken {
  public:
    using Clock = std::chrono::steady_clock;

    StopToken() = default;
    /// Stops at `deadline` (Clock::time_point::max(): never) or once `cancelled` returns true.
    explicit StopToken(Clock::time_point deadline, std::function<bool()> cancelled = {});

    /// False for a token that can never stop (the default): work may then skip what being
    /// interruptible costs.
    bool CanStop() const { return state_ != nullptr; }
    bool StopRequested() const;
    /// OK, or DeadlineExceeded / Cancelled naming `stage` ("deadline expired during chessboard
    /// detection (pair 17 of 200)").
    absl::Status Check(std::string_view stage) const;
    Clock::time_point deadline() const { return deadline_; }

    /// A caller that goes away this close to its deadline went away because of it (a gRPC
    /// client cancels the stream at its deadline, which reaches the server a few ms before the
    /// server's own copy of the deadline passes): the stop is then reported as the deadline's.
    static constexpr std::chrono::milliseconds kDeadlineSlack{250};

  private:
    enum Reason : int { kRunning = 0, kDeadline = 1, kCancelled = 2 };
    struct State {
        std::function<bool()> cancelled;
        std::atomic<int> reason{kRunning};
    };
    Reason Poll() const;

    Clock::time_point deadline_ = Clock::time_point::max();
    std::shared_ptr<State> state_;  // null: never stops
};

}  // namespace soilvol
