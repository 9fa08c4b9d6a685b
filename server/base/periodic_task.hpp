#pragma once

#include <chrono>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>

namespace soilvol::server {

/// Runs a task on its own thread every `every` (the first time one period after the start)
/// until it is destroyed, which waits for a run in progress.
class PeriodicTask {
  public:
    PeriodicTask(std::chrono::milliseconds every, std::function<void()> task);
    ~PeriodicTask();
    PeriodicTask(const PeriodicTask&) = delete;
    PeriodicTask& operator=(const PeriodicTask&) = delete;

  private:
    const std::chrono::milliseconds every_;
    const std::function<void()> task_;
    std::mutex mutex_;
    std::condition_variable stop_;
    bool stopping_ = false;
    std::thread thread_;
};

}  // namespace soilvol::server
