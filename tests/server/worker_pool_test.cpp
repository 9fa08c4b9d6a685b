#include "server/dispatch/worker_pool.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <future>

namespace soilvol::server {
namespace {

WorkerPool::Task Counting(std::atomic<int>& ran, std::atomic<int>& rejected,
                          std::shared_future<void> gate = {}) {
    WorkerPool::Task task;
    task.run = [&ran, gate] {
        if (gate.valid()) gate.wait();
        ++ran;
    };
    task.reject = [&rejected] { ++rejected; };
    return task;
}

TEST(WorkerPool, AcceptsWorkersPlusQueueThenRefusesAtOnce) {
    std::promise<void> open;
    std::shared_future<void> gate = open.get_future().share();
    std::atomic<int> ran{0}, rejected{0};
    WorkerPool pool(2, 3);
    int accepted = 0;
    for (int i = 0; i < 10; ++i) {
        WorkerPool::Task task = Counting(ran, rejected, gate);
        if (pool.TrySubmit(task)) ++accepted;
    }
    EXPECT_EQ(accepted, 5);  // 2 running (or about to) + 3 waiting
    open.set_value();
    EXPECT_TRUE(pool.Shutdown(std::chrono::seconds(10)));
    EXPECT_EQ(ran, 5);
    EXPECT_EQ(rejected, 0);
}

TEST(WorkerPool, ThreadStartRunsOnEveryWorkerBeforeItsTasks) {
    thread_local int prepared = 0;
    std::atomic<int> starts{0}, unprepared{0};
    WorkerPool pool(3, 30, {}, [&starts] {
        prepared = 1;
        ++starts;
    });
    std::atomic<int> ran{0};
    for (int i = 0; i < 30; ++i) {
        WorkerPool::Task task;
        task.run = [&ran, &unprepared] {
            if (prepared != 1) ++unprepared;
            ++ran;
        };
        task.reject = [] {};
        ASSERT_TRUE(pool.TrySubmit(task));
    }
    EXPECT_TRUE(pool.Shutdown(std::chrono::seconds(10)));
    EXPECT_EQ(ran, 30);
    EXPECT_EQ(starts, 3);
    EXPECT_EQ(unprepared, 0);
}

TEST(WorkerPool, ShutdownAfterGraceRejectsWhatWaits) {
    std::promise<void> open;
    std::shared_future<void> gate = open.get_future().share();
    std::atomic<int> ran{0}, rejected{0};
    WorkerPool pool(1, 4);
    for (int i = 0; i < 5; ++i) {
        WorkerPool::Task task = Counting(ran, rejected, gate);
        ASSERT_TRUE(pool.TrySubmit(task));
    }
    std::thread opener([&open] {
        std::this_thread::sleep_for(std::chrono::milliseconds(200));
        open.set_value();
    });
    EXPECT_FALSE(pool.Shutdown(std::chrono::milliseconds(50)));
    opener.join();
    EXPECT_EQ(ran + rejected, 5);
    EXPECT_GE(rejected, 3);  // the one running finishes; at most one more started
    WorkerPool::Task late = Counting(ran, rejected);
    EXPECT_FALSE(pool.TrySubmit(late));
}

TEST(WorkerPool, ManySubmittersLoseNothing) {
    std::atomic<int> ran{0}, rejected{0}, refused{0};
    {
        WorkerPool pool(2, 8);
        std::vector<std::thread> submitters;
        for (int t = 0; t < 4; ++t) {
            submitters.emplace_back([&] {
                for (int i = 0; i < 500; ++i) {
                    WorkerPool::Task task = Counting(ran, rejected);
                    if (!pool.TrySubmit(task)) ++refused;
                }
            });
        }
        for (std::thread& s : submitters) s.join();
        pool.Shutdown(std::chrono::seconds(10));
    }
    EXPECT_EQ(ran + rejected + refused, 2000);
    EXPECT_EQ(rejected, 0);
}

}  // namespace
}  // namespace soilvol::server
