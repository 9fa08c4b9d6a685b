#include "server/options.hpp"

#include <gtest/gtest.h>

namespace soilvol::server {
namespace {

TEST(ServerOptions, DefaultsAreValid) { EXPECT_TRUE(ValidateOptions(ServerOptions{}).ok()); }

TEST(ServerOptions, EachBadValueNamesItsFlag) {
    struct Case {
        const char* flag;
        void (*mutate)(ServerOptions&);
    };
    const Case cases[] = {
        {"--grpc-address", [](ServerOptions& o) { o.grpc_address = "localhost"; }},
        {"--grpc-address", [](ServerOptions& o) { o.grpc_address = "localhost:99999"; }},
        {"--grpc-address", [](ServerOptions& o) { o.grpc_address = ":50051"; }},
        {"--http-address", [](ServerOptions& o) { o.http_address = "0.0.0.0:http"; }},
        {"--http-address", [](ServerOptions& o) { o.http_address = "a b:80"; }},
        {"--data-dir", [](ServerOptions& o) { o.data_dir = ""; }},
        {"--workers", [](ServerOptions& o) { o.workers = -1; }},
        {"--workers", [](ServerOptions& o) { o.workers = 100000; }},
        {"--max-queue", [](ServerOptions& o) { o.max_queue = -3; }},
        {"--max-message-mb", [](ServerOptions& o) { o.max_message_mb = 0; }},
        {"--max-message-mb", [](ServerOptions& o) { o.max_message_mb = 5000; }},
        {"--log-level", [](ServerOptions& o) { o.log_level = "verbose"; }},
        {"--log-format", [](ServerOptions& o) { o.log_format = "xml"; }},
        {"--cors-origin", [](ServerOptions& o) { o.cors_origins = {"dash.example"}; }},
        {"--shutdown-grace-s", [](ServerOptions& o) { o.shutdown_grace_s = -1.0; }},
        {"--http-threads", [](ServerOptions& o) { o.http_threads = -1; }},
    };
    for (const Case& c : cases) {
        ServerOptions options;
        c.mutate(options);
        const absl::Status status = ValidateOptions(options);
        EXPECT_TRUE(absl::IsInvalidArgument(status)) << c.flag;
        EXPECT_NE(status.message().find(c.flag), absl::string_view::npos)
            << c.flag << ": " << status.message();
    }
}

TEST(ServerOptions, IpV6AndPortZeroAreAccepted) {
    ServerOptions options;
    options.grpc_address = "[::1]:0";
    options.http_address = "[::]:8080";
    EXPECT_TRUE(ValidateOptions(options).ok());
}

TEST(ServerOptions, ResolveFillsTheAutomaticValues) {
    ServerOptions options;
    options.workers = 3;
    const ServerOptions resolved = ResolveOptions(options);
    EXPECT_EQ(resolved.workers, 3);
    EXPECT_EQ(resolved.max_queue, 12);
    EXPECT_EQ(resolved.http_threads, 2 * (3 + 12) + 4);
    EXPECT_GE(resolved.cpus, 1);
    const ServerOptions automatic = ResolveOptions(ServerOptions{});
    EXPECT_EQ(automatic.workers, automatic.cpus);  // one worker per available CPU
}

}  // namespace
}  // namespace soilvol::server
