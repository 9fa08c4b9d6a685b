#include "client/connection.hpp"

#include <array>
#include <chrono>
#include <iostream>

namespace soilvol::client {
namespace {

constexpr int kMaxMessageBytes = 256 * 1024 * 1024;

}  // namespace

Connection::Connection(const GlobalOptions& options) : timeout_s_(options.timeout_s) {
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(kMaxMessageBytes);
    args.SetMaxSendMessageSize(kMaxMessageBytes);
    channel_ = grpc::CreateCustomChannel(options.server, grpc::InsecureChannelCredentials(), args);
    soil_ = v1::SoilVolume::NewStub(channel_);
    health_ = grpc::health::v1::Health::NewStub(channel_);
}

std::unique_ptr<grpc::ClientContext> Connection::NewContext() const {
    auto context = std::make_unique<grpc::ClientContext>();
    const auto timeout = std::chrono::duration_cast<std::chrono::system_clock::duration>(
        std::chrono::duration<double>(timeout_s_));
    context->set_deadline(std::chrono::system_clock::now() + timeout);
    return context;
}

std::string StatusCodeName(grpc::StatusCode code) {
    static const std::array<const char*, 17> kNames = {"OK",
                                                       "CANCELLED",
                                                       "UNKNOWN",
                                                       "INVALID_ARGUMENT",
                                                       "DEADLINE_EXCEEDED",
                                                       "NOT_FOUND",
                                                       "ALREADY_EXISTS",
                                                       "PERMISSION_DENIED",
                                                       "RESOURCE_EXHAUSTED",
                                                       "FAILED_PRECONDITION",
                                                       "ABORTED",
                                                       "OUT_OF_RANGE",
                                                       "UNIMPLEMENTED",
                                                       "INTERNAL",
                                                       "UNAVAILABLE",
                                                       "DATA_LOSS",
                                                       "UNAUTHENTICATED"};
    const int index = static_cast<int>(code);
    if (index < 0 || index >= static_cast<int>(kNames.size())) {
        return "CODE_" + std::to_string(index);
    }
    return kNames[static_cast<size_t>(index)];
}

int ReportRpcError(const grpc::Status& status) {
    std::cerr << "error: " << StatusCodeName(status.error_code()) << ": " << status.error_message()
              << "\n";
    return kExitRpcError;
}

}  // namespace soilvol::client
