#include "server/http/http_server.hpp"

#include <pthread.h>

#include <algorithm>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <thread>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "server/base/status_map.hpp"
#include "server/http/connection.hpp"

namespace soilvol::server {
namespace {

namespace beast = boost::beast;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using http_detail::Shared;
using http_detail::StartPlainConnection;
using http_detail::StartTlsConnection;

/// The answer to one connection too many, written without blocking before the close.
const std::string& TooManyConnections() {
    static const std::string kBusy = [] {
        const std::string body = ErrorJson(WithReason(
            absl::UnavailableError("too many connections; retry later"), "TOO_MANY_CONNECTIONS"));
        return absl::StrCat(
            "HTTP/1.1 503 Service Unavailable\r\nContent-Type: application/json\r\n"
            "Retry-After: 1\r\nConnection: close\r\nContent-Length: ",
            body.size(), "\r\n\r\n", body);
    }();
    return kBusy;
}

std::string PeerOf(const tcp::socket& socket) {
    beast::error_code ec;
    const tcp::endpoint remote = socket.remote_endpoint(ec);
    if (ec) return "unknown";
    const net::ip::address address = remote.address();
    return address.is_v6() ? absl::StrCat("[", address.to_string(), "]:", remote.port())
                           : absl::StrCat(address.to_string(), ":", remote.port());
}

}  // namespace

struct HttpServer::Impl {
    std::shared_ptr<Shared> shared = std::make_shared<Shared>();
    net::io_context io;
    std::optional<tcp::acceptor> acceptor;
    std::optional<net::steady_timer> retry;
    std::vector<std::thread> threads;
    bool started = false;

    void Accept() {
        acceptor->async_accept(net::make_strand(io),
                               [this](beast::error_code ec, tcp::socket socket) {
                                   if (ec == net::error::operation_aborted) return;
                                   if (!ec) {
                                       Serve(std::move(socket));
                                       return Accept();
                                   }
                                   // Out of descriptors or memory: wait a moment instead of
                                   // spinning.
                                   retry->expires_after(std::chrono::milliseconds(50));
                                   retry->async_wait([this](beast::error_code wait_ec) {
                                       if (!wait_ec) Accept();
                                   });
                               });
    }

    void Serve(tcp::socket socket) {
        Shared& s = *shared;
        if (s.stats.open.load() >= static_cast<std::int64_t>(s.options.limits.max_connections)) {
            ++s.stats.refused;
            // Best effort, never blocking: the client learns why before the close.
            const std::string& busy = TooManyConnections();
            beast::error_code ignored;
            socket.non_blocking(true, ignored);
            socket.write_some(net::buffer(busy.data(), busy.size()), ignored);
            socket.shutdown(tcp::socket::shutdown_both, ignored);
            return;
        }
        beast::error_code ignored;
        socket.set_option(tcp::no_delay(true), ignored);
        std::string peer = PeerOf(socket);
        if (s.tls) {
            StartTlsConnection(shared, std::move(peer), std::move(socket));
        } else {
            StartPlainConnection(shared, std::move(peer), std::move(socket));
        }
    }
};

HttpServer::HttpServer(HttpServerOptions options, Admit admit, Handle handle)
    : impl_(std::make_unique<Impl>()) {
    impl_->shared->options = std::move(options);
    impl_->shared->admit = std::move(admit);
    impl_->shared->handle = std::move(handle);
}

HttpServer::~HttpServer() { Stop(); }

const HttpConnectionStats& HttpServer::stats() const { return impl_->shared->stats; }

absl::StatusOr<int> HttpServer::Start() {
    Shared& s = *impl_->shared;
    const std::string& address = s.options.address;
    const std::size_t colon = address.rfind(':');
    std::string host = address.substr(0, colon);
    if (host.size() > 2 && host.front() == '[') host = host.substr(1, host.size() - 2);
    int port = 0;
    if (colon == std::string::npos || !absl::SimpleAtoi(address.substr(colon + 1), &port)) {
        return absl::InvalidArgumentError(absl::StrCat("'", address, "' is not host:port"));
    }
    if (s.options.tls.enabled()) {
        s.tls = std::make_unique<TlsContextSource>(s.options.tls);
        if (absl::Status status = s.tls->Load(); !status.ok()) return status;
    }
    beast::error_code ec;
    tcp::resolver resolver(impl_->io);
    const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
    if (ec || endpoints.empty()) {
        return absl::UnavailableError(absl::StrCat("cannot resolve '", host, "'"));
    }
    const tcp::endpoint endpoint = endpoints.begin()->endpoint();
    tcp::acceptor acceptor(net::make_strand(impl_->io));
    acceptor.open(endpoint.protocol(), ec);
    if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
    if (!ec) acceptor.bind(endpoint, ec);
    if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
    if (ec) return absl::UnavailableError(absl::StrCat("cannot listen on ", address));
    const int bound = acceptor.local_endpoint().port();
    impl_->acceptor.emplace(std::move(acceptor));
    impl_->retry.emplace(impl_->acceptor->get_executor());
    impl_->Accept();
    for (int i = 0; i < std::max(1, s.options.io_threads); ++i) {
        impl_->threads.emplace_back([this] {
            pthread_setname_np(pthread_self(), "soilvol-http");  // top -H, perf, gdb
            impl_->io.run();
        });
    }
    impl_->started = true;
    return bound;
}

void HttpServer::Stop() {
    if (!impl_->started) return;
    impl_->started = false;
    impl_->io.stop();
    for (std::thread& thread : impl_->threads) thread.join();
    impl_->threads.clear();
    beast::error_code ignored;
    impl_->acceptor->close(ignored);
}

}  // namespace soilvol::server
