#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "absl/status/statusor.h"
#include "server/http/http_message.hpp"

namespace soilvol::server {

/// What slow, idle or greedy clients may take. Defaults fit a site network: a header must
/// arrive within 10 s of its first byte, a body keep a modest pace, and no connection holds a
/// thread while it waits.
struct HttpLimits {
    std::size_t max_connections = 512;                     ///< beyond: 503 and close, at once
    std::chrono::milliseconds header_timeout{10'000};      ///< first byte to the header's end
    std::chrono::milliseconds idle_timeout{60'000};        ///< keep-alive wait for the next request
    std::chrono::milliseconds write_timeout{60'000};       ///< one response
    std::chrono::milliseconds body_stall_timeout{10'000};  ///< longest wait for body bytes
    /// After body_grace, a body must have come at this average rate [bytes/s] or the request
    /// gets 408 (a slow upload holds a connection and its bytes).
    std::chrono::milliseconds body_grace{10'000};
    std::uint64_t min_body_rate_bytes_s = 16 * 1024;
    std::size_t max_header_bytes = 16 * 1024;
    std::uint64_t max_body_bytes = 64ull << 20;  ///< one request: 413 beyond
    /// All bodies being received or held by requests in progress: beyond it a request gets
    /// 429 with Retry-After before its body is read.
    std::uint64_t max_inflight_body_bytes = 512ull << 20;
};

/// Certificate files for TLS; they are read again when they change (cert-manager rotation).
struct TlsFiles {
    std::string cert_path;       ///< PEM chain, server certificate first
    std::string key_path;        ///< PEM private key
    std::string client_ca_path;  ///< set: clients must present a certificate this CA signed
    bool enabled() const { return !cert_path.empty(); }
};

/// Loads the files as a server would: InvalidArgument naming the flag, the path and OpenSSL's
/// reason for a file that is missing, not PEM, or a key that does not match the certificate.
absl::Status CheckTlsFiles(const TlsFiles& files);

struct HttpServerOptions {
    std::string address = "127.0.0.1:8080";  ///< host:port; port 0 picks a free one
    int io_threads = 2;
    HttpLimits limits;
    TlsFiles tls;
};

/// Counters the server keeps about its connections, for metrics.
struct HttpConnectionStats {
    std::atomic<std::int64_t> open{0};
    std::atomic<std::int64_t> refused{0};        ///< at max_connections
    std::atomic<std::int64_t> timed_out{0};      ///< header, body, idle or write timeouts
    std::atomic<std::int64_t> tls_failures{0};   ///< handshakes that failed
    std::atomic<std::int64_t> inflight_body{0};  ///< bytes held by bodies now
};

/// An HTTP/1.1 server (Boost.Beast on asio, TLS through OpenSSL) that never ties a thread to a
/// connection: slow or idle clients cost a socket and a few kilobytes, are bounded by
/// max_connections, and are cut off by the limits above. Each request goes through `admit`
/// after its header (a response there refuses it without reading the body, as for a bad
/// origin, a missing token or a declared size past the limit), then to `handle` with its body.
/// `handle` runs on an I/O thread and must not block: long work goes elsewhere and answers
/// through the exchange.
class HttpServer {
  public:
    using Admit = std::function<std::optional<HttpResponse>(const HttpRequest& head)>;
    using Handle = std::function<void(HttpRequest request, std::shared_ptr<HttpExchange> exchange)>;

    HttpServer(HttpServerOptions options, Admit admit, Handle handle);
    ~HttpServer();
    HttpServer(const HttpServer&) = delete;
    HttpServer& operator=(const HttpServer&) = delete;

    /// Binds and starts the I/O threads; the bound port. Unavailable when the address cannot be
    /// bound; InvalidArgument for unreadable or mismatched TLS files.
    absl::StatusOr<int> Start();
    /// Stops accepting, closes every connection and joins the I/O threads. Responses still
    /// owed are dropped. Idempotent.
    void Stop();

    const HttpConnectionStats& stats() const;

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace soilvol::server
