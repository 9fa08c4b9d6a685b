#include "server/options.hpp"

#include <gtest/gtest.h>

#include <cmath>

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
        {"--http-max-connections", [](ServerOptions& o) { o.http_max_connections = 0; }},
        {"--http-header-timeout-s", [](ServerOptions& o) { o.http_header_timeout_s = 0.0; }},
        {"--http-idle-timeout-s", [](ServerOptions& o) { o.http_idle_timeout_s = 1e9; }},
        {"--tls-key", [](ServerOptions& o) { o.tls_cert = "cert.pem"; }},
        {"--tls-cert", [](ServerOptions& o) { o.tls_key = "key.pem"; }},
        {"--tls-client-ca", [](ServerOptions& o) { o.tls_client_ca = "ca.pem"; }},
        {"--metrics", [](ServerOptions& o) { o.metrics = "public"; }},
        {"--probe-address", [](ServerOptions& o) { o.probe_address = "8081"; }},
        {"--grpc-max-connection-age-s", [](ServerOptions& o) { o.grpc_max_connection_age_s = -1; }},
        {"--capacity-warning-share", [](ServerOptions& o) { o.capacity_warning_share = 0.0; }},
        {"--capacity-warning-share", [](ServerOptions& o) { o.capacity_warning_share = 1.5; }},
        {"--capacity-warning-share",
         [](ServerOptions& o) { o.capacity_warning_share = std::nan(""); }},
        {"--watch-coalesce-seconds", [](ServerOptions& o) { o.watch_coalesce_s = -0.1; }},
        {"--watch-coalesce-seconds", [](ServerOptions& o) { o.watch_coalesce_s = std::nan(""); }},
        {"--webhook-lease-seconds", [](ServerOptions& o) { o.webhook_lease_s = 9; }},
        {"--webhook-lease-seconds", [](ServerOptions& o) { o.webhook_lease_s = 601; }},
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
    options.allow_unauthenticated = true;
    EXPECT_TRUE(ValidateOptions(options).ok());
}

TEST(ServerOptions, ListeningBeyondLoopbackNeedsCredentialsOrConsent) {
    ServerOptions open;
    open.grpc_address = "0.0.0.0:50051";
    const absl::Status refused = ValidateOptions(open);
    EXPECT_TRUE(absl::IsInvalidArgument(refused));
    EXPECT_NE(refused.message().find("--grpc-address"), absl::string_view::npos);
    EXPECT_NE(refused.message().find("--allow-unauthenticated"), absl::string_view::npos);

    ServerOptions consent = open;
    consent.allow_unauthenticated = true;
    EXPECT_TRUE(ValidateOptions(consent).ok());
    ServerOptions tokens = open;
    tokens.auth_tokens_file = "/etc/soilvol/tokens";
    EXPECT_TRUE(ValidateOptions(tokens).ok());
    ServerOptions mtls = open;
    mtls.tls_cert = "tls.crt";
    mtls.tls_key = "tls.key";
    mtls.tls_client_ca = "ca.crt";
    EXPECT_TRUE(ValidateOptions(mtls).ok());
    ServerOptions tls_only = mtls;
    tls_only.tls_client_ca.clear();
    EXPECT_FALSE(ValidateOptions(tls_only).ok());  // TLS alone authenticates nobody
}

TEST(ServerOptions, LoopbackAddresses) {
    for (const char* address : {"127.0.0.1:1", "127.9.9.9:80", "localhost:0", "[::1]:8080"}) {
        EXPECT_TRUE(IsLoopbackAddress(address)) << address;
    }
    for (const char* address :
         {"0.0.0.0:1", "[::]:80", "10.0.0.1:0", "soilvol:80", "128.0.0.1:1"}) {
        EXPECT_FALSE(IsLoopbackAddress(address)) << address;
    }
}

TEST(ServerOptions, ResolveFillsTheAutomaticValues) {
    ServerOptions options;
    options.workers = 3;
    const ServerOptions resolved = ResolveOptions(options);
    EXPECT_EQ(resolved.workers, 3);
    EXPECT_EQ(resolved.max_queue, 12);
    EXPECT_EQ(resolved.http_threads, 2);
    EXPECT_GE(resolved.cpus, 1);
    const ServerOptions automatic = ResolveOptions(ServerOptions{});
    EXPECT_EQ(automatic.workers, automatic.cpus);  // one worker per available CPU
}

}  // namespace
}  // namespace soilvol::server
