#include "core/common/stop_token.hpp"

#include <utility>

#include "absl/strings/str_cat.h"

namespace soilvol {

StopToken::StopToken(Clock::time_point deadline, std::function<bool()> cancelled)
    : deadline_(deadline) {
    if (deadline == Clock::time_point::max() && !cancelled) return;
    state_ = std::make_shared<State>();
    state_->cancelled = std::move(cancelled);
}

StopToken::Reason StopToken::Poll() const {
    if (state_ == nullptr) return kRunning;
    const int seen = state_->reason.load(std::memory_order_acquire);
    if (seen != kRunning) return static_cast<Reason>(seen);
    Reason now = kRunning;
    const bool has_deadline = deadline_ != Clock::time_point::max();
    const Clock::time_point time = Clock::now();
    if (has_deadline && time >= deadline_) {
        now = kDeadline;
    } else if (state_->cancelled && state_->cancelled()) {
        now = has_deadline && time + kDeadlineSlack >= deadline_ ? kDeadline : kCancelled;
    }
    if (now == kRunning) return kRunning;
    // The first reason seen is the one every later check reports.
    int expected = kRunning;
    state_->reason.compare_exchange_strong(expected, now, std::memory_order_acq_rel);
    return static_cast<Reason>(state_->reason.load(std::memory_order_acquire));
}

bool StopToken::StopRequested() const { return Poll() != kRunning; }

absl::Status StopToken::Check(std::string_view stage_name) const {
    const absl::string_view stage(stage_name.data(), stage_name.size());
    switch (Poll()) {
        case kRunning:
            return absl::OkStatus();
        case kDeadline:
            return absl::DeadlineExceededError(absl::StrCat("deadline expired during ", stage));
        case kCancelled:
            break;
    }
    return absl::CancelledError(absl::StrCat("cancelled during ", stage));
}

}  // namespace soilvol
