#include "server/http/http_server.hpp"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

namespace soilvol::server {
namespace {

using std::chrono::milliseconds;

/// A raw TCP client: what it sends goes out byte for byte, as a slow or hostile client's would.
class RawClient {
  public:
    /// `receive_buffer` > 0: the socket's receive buffer, set before connecting (a small
    /// window, as a stalled reader's).
    explicit RawClient(int port, int receive_buffer = 0) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
        if (receive_buffer > 0) {
            ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &receive_buffer, sizeof(receive_buffer));
        }
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_port = htons(static_cast<std::uint16_t>(port));
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0;
        timeval timeout{10, 0};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    }
    ~RawClient() { ::close(fd_); }
    bool connected() const { return connected_; }
    bool Send(const std::string& bytes) {
        return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) ==
               static_cast<ssize_t>(bytes.size());
    }
    /// Everything until the server closes (or 10 s pass).
    std::string ReadAll() {
        std::string text;
        char buffer[4096];
        for (;;) {
            const ssize_t got = ::recv(fd_, buffer, sizeof(buffer), 0);
            if (got <= 0) return text;
            text.append(buffer, static_cast<std::size_t>(got));
        }
    }
    /// Everything until `marker` has arrived (or the server closes, or 10 s pass).
    std::string ReadUntil(const std::string& marker) {
        char buffer[4096];
        while (pending_.find(marker) == std::string::npos) {
            const ssize_t got = ::recv(fd_, buffer, sizeof(buffer), 0);
            if (got <= 0) break;
            pending_.append(buffer, static_cast<std::size_t>(got));
        }
        std::string text;
        text.swap(pending_);
        return text;
    }
    /// One response: reads until the header and Content-Length bytes of body have arrived.
    std::string ReadResponse() {
        std::string text;
        char buffer[4096];
        for (;;) {
            const std::size_t end = text.find("\r\n\r\n");
            if (end != std::string::npos) {
                const std::size_t at = text.find("Content-Length: ");
                const std::size_t length =
                    at == std::string::npos ? 0 : std::stoul(text.substr(at + 16));
                if (text.size() >= end + 4 + length) return text;
            }
            const ssize_t got = ::recv(fd_, buffer, sizeof(buffer), 0);
            if (got <= 0) return text;
            text.append(buffer, static_cast<std::size_t>(got));
        }
    }

  private:
    int fd_;
    bool connected_ = false;
    std::string pending_;
};

/// `counter` once it reaches `expected`, or its value after a second.
std::int64_t Settled(const std::atomic<std::int64_t>& counter, std::int64_t expected) {
    for (int i = 0; i < 100 && counter.load() != expected; ++i) {
        std::this_thread::sleep_for(milliseconds(10));
    }
    return counter.load();
}

int StatusOf(const std::string& response) {
    return response.size() > 12 ? std::stoi(response.substr(9, 3)) : 0;
}

/// A server whose handler echoes the body's size, with short limits.
class HttpServerTest : public ::testing::Test {
  protected:
    void StartServer(HttpLimits limits = {}) {
        HttpServerOptions options;
        options.address = "127.0.0.1:0";
        options.limits = limits;
        server_ = std::make_unique<HttpServer>(
            options,
            [this](const HttpRequest& head) -> std::optional<HttpResponse> {
                ++admitted_;
                if (head.path == "/refuse") {
                    HttpResponse response;
                    response.status = 403;
                    response.body = "{}";
                    return response;
                }
                return std::nullopt;
            },
            [this](HttpRequest request, std::shared_ptr<HttpExchange> exchange) {
                if (request.path == "/stream") {
                    // Server-Sent Events from another thread: one now, one when released.
                    HttpResponse head;
                    head.content_type = "text/event-stream";
                    head.headers.Set("Cache-Control", "no-store");
                    EXPECT_TRUE(exchange->StartStream(std::move(head)));
                    EXPECT_FALSE(exchange->Gone());
                    std::thread([exchange, this] {
                        exchange->Send("id: 1\ndata: {\"n\":1}\n\n");
                        while (!release_ && !stop_slow_ && !exchange->Gone()) {
                            std::this_thread::sleep_for(milliseconds(5));
                        }
                        // A client that left: Send says so within a few tries.
                        for (int i = 0; i < 200 && exchange->Send(": ping\n\n"); ++i) {
                            if (release_) break;
                            std::this_thread::sleep_for(milliseconds(5));
                        }
                        gone_seen_ = exchange->Gone();
                        exchange->Send("id: 2\ndata: {\"n\":2}\n\n");
                        exchange->Finish();
                    }).detach();
                    return;
                }
                if (request.path == "/burst") {
                    // Three events and the end, posted before the connection's thread (busy
                    // here) can take any of them.
                    HttpResponse head;
                    head.content_type = "text/event-stream";
                    EXPECT_TRUE(exchange->StartStream(std::move(head)));
                    for (int i = 1; i <= 3; ++i) {
                        exchange->Send("id: " + std::to_string(i) + "\n\n");
                    }
                    exchange->Finish();
                    return;
                }
                if (request.path == "/flood") {
                    // 4 KiB every 5 ms for a reader that never reads: the socket's buffers
                    // fill, a write stalls, and the write timeout ends the stream well before
                    // the backlog limit would (1 MiB at 800 KiB/s).
                    HttpResponse head;
                    head.content_type = "text/event-stream";
                    EXPECT_TRUE(exchange->StartStream(std::move(head)));
                    std::thread([exchange, this] {
                        const std::string chunk = ": " + std::string(4094, 'x');
                        while (!stop_slow_ && exchange->Send(chunk)) {
                            std::this_thread::sleep_for(milliseconds(5));
                        }
                        gone_seen_ = exchange->Gone();
                    }).detach();
                    return;
                }
                if (request.path == "/slow") {
                    // Answers from another thread later, as the worker pool does.
                    std::thread([exchange, this] {
                        while (!exchange->Gone() && !stop_slow_) {
                            std::this_thread::sleep_for(milliseconds(10));
                        }
                        gone_seen_ = exchange->Gone();
                        HttpResponse response;
                        response.body = "{}";
                        exchange->Respond(std::move(response));
                    }).detach();
                    return;
                }
                HttpResponse response;
                response.body = "{\"bytes\":" + std::to_string(request.body.size()) + "}";
                response.headers.Set("X-Query", request.query);
                exchange->Respond(std::move(response));
            });
        absl::StatusOr<int> port = server_->Start();
        ASSERT_TRUE(port.ok()) << port.status();
        port_ = *port;
    }
    void TearDown() override {
        stop_slow_ = true;
        std::this_thread::sleep_for(milliseconds(30));
        if (server_) server_->Stop();
    }

    std::unique_ptr<HttpServer> server_;
    int port_ = 0;
    std::atomic<int> admitted_{0};
    std::atomic<bool> stop_slow_{false};
    std::atomic<bool> gone_seen_{false};
    std::atomic<bool> release_{false};
};

TEST_F(HttpServerTest, StreamedResponsesArriveChunkByChunkAndKeepTheConnection) {
    StartServer();
    RawClient client(port_);
    ASSERT_TRUE(client.Send("GET /stream HTTP/1.1\r\nHost: x\r\n\r\n"));
    // The first event arrives while the stream is still open.
    const std::string first = client.ReadUntil("data: {\"n\":1}");
    EXPECT_EQ(StatusOf(first), 200) << first;
    EXPECT_NE(first.find("Transfer-Encoding: chunked"), std::string::npos) << first;
    EXPECT_NE(first.find("Content-Type: text/event-stream"), std::string::npos) << first;
    EXPECT_EQ(first.find("id: 2"), std::string::npos);
    release_ = true;
    const std::string rest = client.ReadUntil("\r\n0\r\n\r\n");
    EXPECT_NE(rest.find("id: 2\ndata: {\"n\":2}"), std::string::npos) << rest;
    // The connection serves the next request.
    ASSERT_TRUE(client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 3\r\n\r\nabc"));
    const std::string next = client.ReadResponse();
    EXPECT_EQ(StatusOf(next), 200) << next;
    EXPECT_NE(next.find("{\"bytes\":3}"), std::string::npos) << next;
}

TEST_F(HttpServerTest, ChunksPostedBeforeTheConnectionTookThemLeaveAsOne) {
    StartServer();
    RawClient client(port_);
    ASSERT_TRUE(client.Send("GET /burst HTTP/1.1\r\nHost: x\r\n\r\n"));
    const std::string response = client.ReadUntil("\r\n0\r\n\r\n");
    const std::size_t body = response.find("\r\n\r\n");
    ASSERT_NE(body, std::string::npos) << response;
    // One HTTP chunk of 21 bytes (hex 15), in order, then the last chunk.
    EXPECT_EQ(response.substr(body + 4), "15\r\nid: 1\n\nid: 2\n\nid: 3\n\n\r\n0\r\n\r\n");
}

TEST_F(HttpServerTest, AStreamSeesItsClientLeave) {
    StartServer();
    {
        RawClient client(port_);
        ASSERT_TRUE(client.Send("GET /stream HTTP/1.1\r\nHost: x\r\n\r\n"));
        client.ReadUntil("data: {\"n\":1}");
    }  // gone while the stream waits for its next event
    for (int i = 0; i < 200 && !gone_seen_; ++i) std::this_thread::sleep_for(milliseconds(10));
    EXPECT_TRUE(gone_seen_);
}

TEST_F(HttpServerTest, AStreamWhoseReaderStopsReadingEndsAtTheWriteTimeout) {
    HttpLimits limits;
    limits.write_timeout = milliseconds(300);
    StartServer(limits);
    RawClient client(port_, 4096);
    ASSERT_TRUE(client.Send("GET /flood HTTP/1.1\r\nHost: x\r\n\r\n"));
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < 1000 && !gone_seen_; ++i) std::this_thread::sleep_for(milliseconds(10));
    EXPECT_TRUE(gone_seen_);
    const auto took = std::chrono::steady_clock::now() - start;
    std::printf("stalled stream ended after %.2f s\n", std::chrono::duration<double>(took).count());
    EXPECT_LT(took, std::chrono::seconds(8));  // mostly the socket buffers filling
    EXPECT_EQ(Settled(server_->stats().timed_out, 1), 1);
}

TEST_F(HttpServerTest, ServesKeepAliveRequestsOnOneConnection) {
    StartServer();
    RawClient client(port_);
    ASSERT_TRUE(client.connected());
    for (int i = 0; i < 3; ++i) {
        ASSERT_TRUE(client.Send("POST /echo?i=" + std::to_string(i) +
                                " HTTP/1.1\r\nHost: x\r\nContent-Length: 5\r\n\r\nhello"));
        const std::string response = client.ReadResponse();
        EXPECT_EQ(StatusOf(response), 200) << response;
        EXPECT_NE(response.find("{\"bytes\":5}"), std::string::npos) << response;
        EXPECT_NE(response.find("X-Query: i=" + std::to_string(i)), std::string::npos);
    }
}

TEST_F(HttpServerTest, ChunkedBodiesAreReadAndExpectContinueIsAnswered) {
    StartServer();
    RawClient client(port_);
    ASSERT_TRUE(
        client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"
                    "3\r\nabc\r\n4\r\ndefg\r\n0\r\n\r\n"));
    EXPECT_NE(client.ReadResponse().find("{\"bytes\":7}"), std::string::npos);
    ASSERT_TRUE(
        client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nExpect: 100-continue\r\n"
                    "Content-Length: 2\r\n\r\n"));
    EXPECT_EQ(StatusOf(client.ReadResponse()), 100);
    ASSERT_TRUE(client.Send("ok"));
    EXPECT_NE(client.ReadResponse().find("{\"bytes\":2}"), std::string::npos);
}

TEST_F(HttpServerTest, DeclaredOrChunkedBodiesPastTheLimitGet413) {
    HttpLimits limits;
    limits.max_body_bytes = 1000;
    StartServer(limits);
    {
        RawClient client(port_);
        ASSERT_TRUE(client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 1001\r\n\r\n"));
        EXPECT_EQ(StatusOf(client.ReadAll()), 413);
    }
    {
        RawClient client(port_);
        std::string request =
            "POST /echo HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n";
        for (int i = 0; i < 20; ++i) request += "64\r\n" + std::string(100, 'x') + "\r\n";
        client.Send(request);
        EXPECT_EQ(StatusOf(client.ReadAll()), 413);
    }
}

TEST_F(HttpServerTest, AdmitRefusesBeforeTheBodyIsRead) {
    StartServer();
    RawClient client(port_);
    // The body is announced but never sent: the refusal must not wait for it.
    ASSERT_TRUE(client.Send("POST /refuse HTTP/1.1\r\nHost: x\r\nContent-Length: 100000\r\n\r\n"));
    const std::string response = client.ReadAll();
    EXPECT_EQ(StatusOf(response), 403) << response;
    EXPECT_NE(response.find("Connection: close"), std::string::npos);
}

TEST_F(HttpServerTest, SlowHeaderIsCutOffAtTheHeaderTimeout) {
    HttpLimits limits;
    limits.header_timeout = milliseconds(300);
    StartServer(limits);
    RawClient client(port_);
    ASSERT_TRUE(client.Send("GET /echo HTTP/1.1\r\n"));
    const auto start = std::chrono::steady_clock::now();
    // A byte every 50 ms for up to 2 s: each one is progress, but the header never ends.
    for (int i = 0; i < 40 && client.Send("X"); ++i) std::this_thread::sleep_for(milliseconds(50));
    client.ReadAll();  // ends when the server closes (10 s when it does not)
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
    EXPECT_EQ(Settled(server_->stats().timed_out, 1), 1);
    EXPECT_EQ(admitted_.load(), 0);
}

TEST_F(HttpServerTest, StalledBodyIsCutOff) {
    HttpLimits limits;
    limits.body_stall_timeout = milliseconds(300);
    StartServer(limits);
    RawClient client(port_);
    const auto start = std::chrono::steady_clock::now();
    ASSERT_TRUE(client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 10\r\n\r\nabc"));
    EXPECT_EQ(client.ReadAll(), "");  // closed, never handled
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
    EXPECT_EQ(Settled(server_->stats().timed_out, 1), 1);
}

TEST_F(HttpServerTest, BodyBelowTheMinimumRateGets408) {
    HttpLimits limits;
    limits.body_grace = milliseconds(200);
    limits.min_body_rate_bytes_s = 1000;
    StartServer(limits);
    RawClient client(port_);
    ASSERT_TRUE(client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\n"));
    for (int i = 0; i < 10 && client.Send("x"); ++i) std::this_thread::sleep_for(milliseconds(50));
    EXPECT_EQ(StatusOf(client.ReadAll()), 408);
}

TEST_F(HttpServerTest, ConnectionsPastTheCapGet503AndTheOthersAreServed) {
    HttpLimits limits;
    limits.max_connections = 4;
    StartServer(limits);
    std::vector<std::unique_ptr<RawClient>> idle;
    for (int i = 0; i < 4; ++i) {
        idle.push_back(std::make_unique<RawClient>(port_));
        ASSERT_TRUE(idle.back()->Send("G"));  // started, never finished
    }
    std::this_thread::sleep_for(milliseconds(100));
    RawClient extra(port_);
    const std::string refused = extra.ReadAll();
    EXPECT_EQ(StatusOf(refused), 503) << refused;
    EXPECT_EQ(Settled(server_->stats().refused, 1), 1);
    idle.clear();  // closing them frees their places
    std::this_thread::sleep_for(milliseconds(100));
    RawClient next(port_);
    ASSERT_TRUE(next.Send("GET /echo HTTP/1.1\r\nHost: x\r\n\r\n"));
    EXPECT_EQ(StatusOf(next.ReadResponse()), 200);
}

TEST_F(HttpServerTest, InflightBodyBudgetAnswers429BeforeReading) {
    HttpLimits limits;
    limits.max_inflight_body_bytes = 1000;
    StartServer(limits);
    RawClient holder(port_);  // holds 800 bytes of budget while its body trickles
    ASSERT_TRUE(holder.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 800\r\n\r\nab"));
    std::this_thread::sleep_for(milliseconds(100));
    RawClient client(port_);
    ASSERT_TRUE(client.Send("POST /echo HTTP/1.1\r\nHost: x\r\nContent-Length: 300\r\n\r\n"));
    const std::string response = client.ReadAll();
    EXPECT_EQ(StatusOf(response), 429) << response;
    EXPECT_NE(response.find("Retry-After: 1"), std::string::npos);
}

TEST_F(HttpServerTest, ClientThatLeavesIsSeenAsGone) {
    StartServer();
    {
        RawClient client(port_);
        ASSERT_TRUE(client.Send("GET /slow HTTP/1.1\r\nHost: x\r\n\r\n"));
        std::this_thread::sleep_for(milliseconds(100));
    }  // closed while the work runs
    for (int i = 0; i < 100 && !gone_seen_; ++i) std::this_thread::sleep_for(milliseconds(20));
    EXPECT_TRUE(gone_seen_);
}

TEST_F(HttpServerTest, MalformedRequestsGet400AndOversizeHeaders431) {
    HttpLimits limits;
    limits.max_header_bytes = 1024;
    StartServer(limits);
    {
        RawClient client(port_);
        ASSERT_TRUE(client.Send("\x16\x03\x01 not http\r\n\r\n"));
        EXPECT_EQ(StatusOf(client.ReadAll()), 400);
    }
    {
        RawClient client(port_);
        client.Send("GET / HTTP/1.1\r\nX: " + std::string(4096, 'a') + "\r\n\r\n");
        EXPECT_EQ(StatusOf(client.ReadAll()), 431);
    }
}

}  // namespace
}  // namespace soilvol::server
