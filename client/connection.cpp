#include "client/connection.hpp"

#include <array>
#include <cctype>
#include <chrono>
#include <iostream>
#include <optional>
#include <tuple>

#include "client/input_files.hpp"

namespace soilvol::client {
namespace {

constexpr int kMaxMessageBytes = 256 * 1024 * 1024;
constexpr std::size_t kMaxFileBytes = 1 << 20;

// The contents of a small file (a PEM file, a token); nullopt, reported, when unreadable.
std::optional<std::string> ReadSmall(const std::string& path, const char* flag) {
    absl::StatusOr<std::string> text = ReadFile(path);
    if (!text.ok()) {
        std::cerr << "error: " << flag << ": " << text.status().message() << "\n";
        return std::nullopt;
    }
    if (text->size() > kMaxFileBytes) {
        std::cerr << "error: " << flag << ": " << path << " is larger than 1 MiB\n";
        return std::nullopt;
    }
    return *std::move(text);
}

}  // namespace

Connection::Connection(const GlobalOptions& options) : timeout_s_(options.timeout_s) {
    grpc::ChannelArguments args;
    args.SetMaxReceiveMessageSize(kMaxMessageBytes);
    args.SetMaxSendMessageSize(kMaxMessageBytes);
    std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
    if (options.tls || !options.tls_ca.empty() || !options.tls_client_cert.empty()) {
        grpc::SslCredentialsOptions ssl;
        for (const auto& [path, out, flag] :
             {std::tuple{options.tls_ca, &ssl.pem_root_certs, "--tls-ca"},
              std::tuple{options.tls_client_cert, &ssl.pem_cert_chain, "--tls-client-cert"},
              std::tuple{options.tls_client_key, &ssl.pem_private_key, "--tls-client-key"}}) {
            if (path.empty()) continue;
            std::optional<std::string> text = ReadSmall(path, flag);
            ok_ = ok_ && text.has_value();
            if (text) *out = std::move(*text);
        }
        credentials = grpc::SslCredentials(ssl);
        if (!options.tls_server_name.empty()) {
            args.SetSslTargetNameOverride(options.tls_server_name);
        }
    }
    std::string token = options.token;
    if (token.empty() && !options.token_file.empty()) {
        std::optional<std::string> text = ReadSmall(options.token_file, "--token-file");
        ok_ = ok_ && text.has_value();
        token = text.value_or("");
        while (!token.empty() && std::isspace(static_cast<unsigned char>(token.back()))) {
            token.pop_back();
        }
    }
    if (!token.empty()) authorization_ = "Bearer " + token;
    channel_ = grpc::CreateCustomChannel(options.server, credentials, args);
    soil_ = v1::SoilVolume::NewStub(channel_);
    health_ = grpc::health::v1::Health::NewStub(channel_);
}

std::unique_ptr<grpc::ClientContext> Connection::NewContext() const {
    auto context = std::make_unique<grpc::ClientContext>();
    const auto timeout = std::chrono::duration_cast<std::chrono::system_clock::duration>(
        std::chrono::duration<double>(timeout_s_));
    context->set_deadline(std::chrono::system_clock::now() + timeout);
    if (!authorization_.empty()) context->AddMetadata("authorization", authorization_);
    return context;
}

std::unique_ptr<grpc::ClientContext> Connection::NewOpenContext() const {
    auto context = std::make_unique<grpc::ClientContext>();
    if (!authorization_.empty()) context->AddMetadata("authorization", authorization_);
    return context;
}

std::string StatusCodeName(int code) {
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
    const int index = code;
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
