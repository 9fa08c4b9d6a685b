#include "server/dispatch/dispatcher.hpp"

#include <gtest/gtest.h>

#include <future>
#include <mutex>
#include <thread>

namespace soilvol::server {
namespace {

using Completion = std::function<void(absl::Status)>;

class DispatcherTest : public ::testing::Test {
  protected:
    DispatcherTest()
        : pool_(1, 4),
          authenticator_(std::move(Authenticator::Create({})).value()),
          dispatcher_(pool_, metrics_, *authenticator_) {}
    ~DispatcherTest() override { pool_.Shutdown(std::chrono::seconds(10)); }

    static CallContext Call() {
        CallContext context;
        context.method = "EstimateVolume";
        context.transport = "grpc";
        return context;
    }

    /// Submits a call whose handler returns `handler_status` after setting a late step that
    /// hands its completion to `*late` (when `late` is set); the future gets the call's status.
    std::future<absl::Status> Submit(CallContext context, absl::Status handler_status,
                                     std::shared_ptr<std::promise<Completion>> late) {
        auto answer = std::make_shared<std::promise<absl::Status>>();
        std::future<absl::Status> answered = answer->get_future();
        dispatcher_.Submit(
            std::move(context),
            [handler_status, late](CallRecord& record) {
                if (late != nullptr) {
                    record.finish_later = [late](Completion finish) {
                        late->set_value(std::move(finish));
                    };
                }
                return handler_status;
            },
            [answer](const absl::Status& status) { answer->set_value(status); });
        return answered;
    }

    static bool Ready(std::future<absl::Status>& answer, std::chrono::milliseconds wait) {
        return answer.wait_for(wait) == std::future_status::ready;
    }

    WorkerPool pool_;
    Metrics metrics_;
    std::unique_ptr<Authenticator> authenticator_;
    Dispatcher dispatcher_;
};

TEST_F(DispatcherTest, ALateStepFreesTheWorkerAndTheCallEndsWhenItCompletes) {
    auto late = std::make_shared<std::promise<Completion>>();
    std::future<Completion> handed = late->get_future();
    std::future<absl::Status> first = Submit(Call(), absl::OkStatus(), late);
    ASSERT_EQ(handed.wait_for(std::chrono::seconds(10)), std::future_status::ready);
    Completion finish = handed.get();
    // The one worker is free: the next call runs and ends while the first one waits.
    std::future<absl::Status> second = Submit(Call(), absl::OkStatus(), nullptr);
    ASSERT_TRUE(Ready(second, std::chrono::seconds(10)));
    EXPECT_TRUE(second.get().ok());
    EXPECT_FALSE(Ready(first, std::chrono::milliseconds(50)));
    std::thread([finish] { finish(absl::OkStatus()); }).join();  // from any thread
    ASSERT_TRUE(Ready(first, std::chrono::seconds(10)));
    EXPECT_TRUE(first.get().ok());
}

TEST_F(DispatcherTest, ALateStepsErrorIsTheCallsAnswer) {
    auto late = std::make_shared<std::promise<Completion>>();
    std::future<Completion> handed = late->get_future();
    std::future<absl::Status> answer = Submit(Call(), absl::OkStatus(), late);
    handed.get()(absl::UnavailableError("the estimate could not be recorded"));
    ASSERT_TRUE(Ready(answer, std::chrono::seconds(10)));
    const absl::Status status = answer.get();
    EXPECT_EQ(status.code(), absl::StatusCode::kUnavailable);
    EXPECT_EQ(status.message(), "the estimate could not be recorded");
}

TEST_F(DispatcherTest, ALateStepThatEndsPastTheDeadlineAnswersDeadlineExceeded) {
    CallContext context = Call();
    context.deadline = Clock::now() + std::chrono::milliseconds(200);
    auto late = std::make_shared<std::promise<Completion>>();
    std::future<Completion> handed = late->get_future();
    std::future<absl::Status> answer = Submit(context, absl::OkStatus(), late);
    Completion finish = handed.get();
    std::this_thread::sleep_until(context.deadline + std::chrono::milliseconds(10));
    finish(absl::OkStatus());
    ASSERT_TRUE(Ready(answer, std::chrono::seconds(10)));
    EXPECT_EQ(answer.get().code(), absl::StatusCode::kDeadlineExceeded);
}

TEST_F(DispatcherTest, AHandlerErrorEndsTheCallAndItsLateStepNeverRuns) {
    auto late = std::make_shared<std::promise<Completion>>();
    std::future<Completion> handed = late->get_future();
    std::future<absl::Status> answer =
        Submit(Call(), absl::InvalidArgumentError("scan: empty"), late);
    ASSERT_TRUE(Ready(answer, std::chrono::seconds(10)));
    EXPECT_EQ(answer.get().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(handed.wait_for(std::chrono::milliseconds(50)), std::future_status::timeout);
}

TEST_F(DispatcherTest, AnInternalErrorsDetailsStayInTheLog) {
    std::future<absl::Status> answer =
        Submit(Call(), absl::InternalError("/usr/include/opencv4/core.hpp:12 failed"), nullptr);
    ASSERT_TRUE(Ready(answer, std::chrono::seconds(10)));
    const absl::Status status = answer.get();
    EXPECT_EQ(status.code(), absl::StatusCode::kInternal);
    EXPECT_EQ(status.message().find("opencv"), absl::string_view::npos);
}

}  // namespace
}  // namespace soilvol::server
