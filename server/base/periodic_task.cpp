#include "server/base/periodic_task.hpp"

namespace soilvol::server {

PeriodicTask::PeriodicTask(std::chrono::milliseconds every, std::function<void()> task)
    : every_(every), task_(std::move(task)) {
    thread_ = std::thread([this] {
        std::unique_lock<std::mutex> lock(mutex_);
        while (!stop_.wait_for(lock, every_, [this] { return stopping_; })) {
            lock.unlock();
            task_();
            lock.lock();
        }
    });
}

PeriodicTask::~PeriodicTask() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        stopping_ = true;
    }
    stop_.notify_all();
    thread_.join();
}

}  // namespace soilvol::server
