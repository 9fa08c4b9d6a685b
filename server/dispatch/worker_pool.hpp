#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace soilvol::server {

/// A fixed set of threads with a bounded queue. A task is accepted only when a worker is idle
/// or the queue has room, so a busy server refuses at once instead of piling up work.
class WorkerPool {
  public:
    /// One unit of work: `run` on a worker, or `reject` (on the shutting-down thread) when the
    /// pool stops before the task started. Exactly one of the two is called.
    struct Task {
        std::function<void()> run;
        std::function<void()> reject;
    };

    /// Called with (running, queued) after every change, under the pool's lock: keep it cheap.
    using LoadListener = std::function<void(std::size_t running, std::size_t queued)>;

    /// `thread_start` runs first on each worker thread (per-thread settings such as the
    /// engine's thread count).
    WorkerPool(int workers, int max_queue, LoadListener listener = {},
               std::function<void()> thread_start = {});
    ~WorkerPool();
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    /// False (and the task untouched) when all workers are busy and max_queue tasks wait, or
    /// the pool is stopping.
    bool TrySubmit(Task& task);

    /// Stops accepting, lets queued and running tasks finish for up to `grace`, then rejects
    /// what is still queued, calls `overrun` when tasks still run (to make them stop), and
    /// joins the workers once the running tasks return. True when nothing had to be rejected.
    bool Shutdown(std::chrono::milliseconds grace, const std::function<void()>& overrun = {});

    std::size_t queued() const;
    std::size_t running() const;
    int workers() const { return static_cast<int>(threads_.size()); }
    std::size_t max_queue() const { return max_queue_; }

  private:
    void Loop();
    void NotifyLocked() const {
        if (listener_) listener_(running_, queue_.size());
    }

    const std::size_t max_queue_;
    const LoadListener listener_;
    mutable std::mutex mutex_;
    std::condition_variable work_ready_;
    std::condition_variable idle_;
    std::deque<Task> queue_;
    std::size_t running_ = 0;
    bool stopping_ = false;
    std::vector<std::thread> threads_;
};

}  // namespace soilvol::server
