#include "core/common/stop_token.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "tests/core/common/counting_stop.hpp"

namespace soilvol {
namespace {

using Clock = StopToken::Clock;
using std::chrono::hours;

TEST(StopTokenTest, DefaultTokenNeverStops) {
    const StopToken stop;
    EXPECT_FALSE(stop.CanStop());
    EXPECT_FALSE(stop.StopRequested());
    EXPECT_TRUE(stop.Check("anything").ok());
    EXPECT_EQ(stop.deadline(), Clock::time_point::max());
    EXPECT_FALSE(StopToken(Clock::time_point::max()).CanStop());
}

TEST(StopTokenTest, FutureDeadlineDoesNotStop) {
    const StopToken stop(Clock::now() + hours(1));
    EXPECT_TRUE(stop.CanStop());
    EXPECT_FALSE(stop.StopRequested());
    EXPECT_TRUE(stop.Check("stage").ok());
}

TEST(StopTokenTest, ExpiredDeadlineIsDeadlineExceededNamingTheStage) {
    const StopToken stop(Clock::now() - hours(1));
    EXPECT_TRUE(stop.StopRequested());
    const absl::Status status = stop.Check("chessboard detection (pair 17 of 200)");
    EXPECT_EQ(status.code(), absl::StatusCode::kDeadlineExceeded);
    EXPECT_EQ(status.message(), "deadline expired during chessboard detection (pair 17 of 200)");
}

TEST(StopTokenTest, CallerGoneIsCancelledNamingTheStage) {
    const StopToken stop(Clock::time_point::max(), [] { return true; });
    const absl::Status status = stop.Check("alignment");
    EXPECT_EQ(status.code(), absl::StatusCode::kCancelled);
    EXPECT_EQ(status.message(), "cancelled during alignment");
}

// A gRPC client cancels at its own deadline, which reaches the server just before the server's
// copy of it passes: that stop is the deadline's. A cancel well before the deadline is a cancel.
TEST(StopTokenTest, CallerGoneAtItsDeadlineIsTheDeadlines) {
    const StopToken at_deadline(Clock::now() + StopToken::kDeadlineSlack / 2, [] { return true; });
    EXPECT_EQ(at_deadline.Check("estimate").code(), absl::StatusCode::kDeadlineExceeded);
    const StopToken early(Clock::now() + StopToken::kDeadlineSlack * 20, [] { return true; });
    EXPECT_EQ(early.Check("estimate").code(), absl::StatusCode::kCancelled);
}

// The first reason seen is kept: a call that was cancelled does not turn into one that ran out
// of time, and the callback is not asked again.
TEST(StopTokenTest, AStopStaysWithItsFirstReason) {
    std::atomic<int> calls{0};
    const StopToken stop(Clock::now() + hours(1), [&] { return ++calls == 1; });
    EXPECT_TRUE(stop.StopRequested());
    EXPECT_TRUE(stop.StopRequested());
    EXPECT_EQ(stop.Check("x").code(), absl::StatusCode::kCancelled);
    EXPECT_EQ(calls.load(), 1);
}

TEST(StopTokenTest, CopiesShareTheStop) {
    const test::CountingStop counting(1);
    const StopToken copy = counting.token();
    EXPECT_TRUE(counting.token().StopRequested());
    EXPECT_TRUE(copy.StopRequested());
    EXPECT_EQ(copy.Check("x").code(), absl::StatusCode::kCancelled);
    EXPECT_EQ(counting.looks(), 1);
}

TEST(StopTokenTest, CountingCallbackStopsAtItsLook) {
    const test::CountingStop counting(3);
    EXPECT_TRUE(counting.token().Check("1").ok());
    EXPECT_TRUE(counting.token().Check("2").ok());
    EXPECT_EQ(counting.token().Check("3").code(), absl::StatusCode::kCancelled);
    EXPECT_TRUE(counting.token().StopRequested());
    EXPECT_EQ(counting.looks(), 3);
}

// Checked from many threads at once (as OpenMP loops do): every thread sees the stop once the
// callback reported it, and the callback is asked at most once more by each other thread.
TEST(StopTokenTest, ThreadsAgreeOnAStop) {
    constexpr long kStopAt = 1000;
    const test::CountingStop counting(kStopAt);
    std::vector<std::thread> threads;
    std::atomic<int> saw_stop{0};
    for (int t = 0; t < 8; ++t) {
        threads.emplace_back([&] {
            while (!counting.token().StopRequested()) {
            }
            ++saw_stop;
        });
    }
    for (std::thread& thread : threads) thread.join();
    EXPECT_EQ(saw_stop.load(), 8);
    EXPECT_GE(counting.looks(), kStopAt);
    EXPECT_LT(counting.looks(), kStopAt + 8);
}

}  // namespace
}  // namespace soilvol
