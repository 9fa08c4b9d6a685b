#include "server/dispatch/worker_pool.hpp"

#include <algorithm>
#include <utility>

namespace soilvol::server {

WorkerPool::WorkerPool(int workers, int max_queue, LoadListener listener,
                       std::function<void()> thread_start)
    : max_queue_(static_cast<std::size_t>(max_queue)), listener_(std::move(listener)) {
    threads_.reserve(static_cast<std::size_t>(workers));
    for (int i = 0; i < workers; ++i) {
        threads_.emplace_back([this, thread_start] {
            if (thread_start) thread_start();
            Loop();
        });
    }
}

WorkerPool::~WorkerPool() { Shutdown(std::chrono::milliseconds(0)); }

bool WorkerPool::TrySubmit(Task& task) {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        const std::size_t idle_workers = threads_.size() - std::min(threads_.size(), running_);
        if (stopping_ || queue_.size() >= max_queue_ + idle_workers) return false;
        queue_.push_back(std::move(task));
        NotifyLocked();
    }
    work_ready_.notify_one();
    return true;
}

void WorkerPool::Loop() {
    for (;;) {
        Task task;
        {
            std::unique_lock<std::mutex> lock(mutex_);
            work_ready_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
            if (queue_.empty()) return;
            task = std::move(queue_.front());
            queue_.pop_front();
            ++running_;
            NotifyLocked();
        }
        task.run();
        {
            std::lock_guard<std::mutex> lock(mutex_);
            --running_;
            NotifyLocked();
        }
        idle_.notify_all();
    }
}

bool WorkerPool::Shutdown(std::chrono::milliseconds grace, const std::function<void()>& overrun) {
    std::deque<Task> rejected;
    bool still_running = false;
    {
        std::unique_lock<std::mutex> lock(mutex_);
        if (threads_.empty()) return true;
        idle_.wait_for(lock, grace, [this] { return queue_.empty() && running_ == 0; });
        stopping_ = true;
        rejected.swap(queue_);
        still_running = running_ > 0;
        NotifyLocked();
    }
    work_ready_.notify_all();
    if (still_running && overrun) overrun();
    for (Task& task : rejected) task.reject();
    for (std::thread& thread : threads_) thread.join();
    threads_.clear();
    return rejected.empty();
}

std::size_t WorkerPool::queued() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return queue_.size();
}

std::size_t WorkerPool::running() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return running_;
}

}  // namespace soilvol::server
