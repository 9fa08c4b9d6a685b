#pragma once

// Shared by the core tests: a stop token whose caller goes away at a chosen look.

#include <atomic>
#include <memory>

#include "core/common/stop_token.hpp"

namespace soilvol::test {

/// A token whose `cancelled` callback counts the looks and reports the caller gone from the
/// `stop_at`-th look on (1: the first; 0: never). A stopped token stays stopped without asking
/// again, so after a stop looks() == stop_at (checked from one thread at a time).
class CountingStop {
  public:
    explicit CountingStop(long stop_at)
        : looks_(std::make_shared<std::atomic<long>>(0)),
          token_(StopToken::Clock::time_point::max(),
                 [looks = looks_, stop_at] { return ++*looks >= stop_at && stop_at > 0; }) {}

    const StopToken& token() const { return token_; }
    long looks() const { return looks_->load(); }

  private:
    std::shared_ptr<std::atomic<long>> looks_;
    StopToken token_;
};

}  // namespace soilvol::test
