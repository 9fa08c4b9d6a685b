#pragma once

#include <chrono>
#include <thread>

#include "client/connection.hpp"

namespace soilvol::client {

/// A watch (WatchEstimates, WatchAlerts, WatchLoads) printed message by message until interrupted,
/// or until `count` messages (0: no end). `open(stub, context, request)` starts the stream, `print`
/// shows a message and `resume(request, message)` sets where to resume after it: a stream the
/// server ends (UNAVAILABLE, RESOURCE_EXHAUSTED) is reopened after the last one printed, 20 times
/// at most a second apart. The exit code.
template <typename Message, typename Request, typename Open, typename Print, typename Resume>
int RunResumableWatch(Connection& connection, Request request, int count, Open open, Print print,
                      Resume resume) {
    int printed = 0;
    for (int attempt = 0;; ++attempt) {
        const auto context = connection.NewOpenContext();
        auto reader = open(connection.Soil(), context.get(), request);
        Message message;
        while (reader->Read(&message)) {
            print(message);
            resume(request, message);
            if (count > 0 && ++printed >= count) {
                context->TryCancel();
                reader->Finish().IgnoreError();
                return kExitOk;
            }
        }
        const grpc::Status status = reader->Finish();
        const bool resumable = status.error_code() == grpc::StatusCode::UNAVAILABLE ||
                               status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED;
        if (!resumable || attempt >= 20) return ReportRpcError(status);
        std::this_thread::sleep_for(std::chrono::seconds(1));
    }
}

}  // namespace soilvol::client
