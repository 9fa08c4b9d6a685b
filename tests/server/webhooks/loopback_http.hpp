#pragma once

// A loopback HTTP/1.1 server for the webhook tests: it answers each connection with scripted
// bytes and keeps the requests it read.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"

namespace soilvol::server::testing_http {

// A listening socket on 127.0.0.1 and an ephemeral port; closed at scope exit.
class LoopbackListener {
  public:
    LoopbackListener() {
        fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        sockaddr_in address{};
        address.sin_family = AF_INET;
        address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
        socklen_t length = sizeof(address);
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&address), length) != 0 ||
            ::listen(fd_, 8) != 0 ||
            ::getsockname(fd_, reinterpret_cast<sockaddr*>(&address), &length) != 0) {
            ADD_FAILURE() << "cannot listen on 127.0.0.1";
        }
        port_ = ntohs(address.sin_port);
    }
    ~LoopbackListener() { Close(); }
    LoopbackListener(const LoopbackListener&) = delete;
    LoopbackListener& operator=(const LoopbackListener&) = delete;

    void Close() {
        if (fd_ >= 0) ::close(fd_);
        fd_ = -1;
    }
    int fd() const { return fd_; }
    int port() const { return port_; }

  private:
    int fd_ = -1;
    int port_ = 0;
};

// The head and the Content-Length body of one request, or what came within 5 s.
inline std::string ReadHttpRequest(int fd) {
    const timeval timeout{5, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof(timeout));
    std::string request;
    char chunk[4096];
    std::size_t wanted = std::string::npos;
    while (request.size() < wanted) {
        const ssize_t got = ::recv(fd, chunk, sizeof(chunk), 0);
        if (got <= 0) break;
        request.append(chunk, static_cast<std::size_t>(got));
        const std::size_t head_end = request.find("\r\n\r\n");
        if (wanted != std::string::npos || head_end == std::string::npos) continue;
        const std::string head = absl::AsciiStrToLower(request.substr(0, head_end));
        const std::size_t field = head.find("\r\ncontent-length: ");
        const std::size_t body =
            field == std::string::npos ? 0 : std::stoul(head.substr(field + 18));
        wanted = head_end + 4 + body;
    }
    return request;
}

// Answers connections one at a time with `responses` in turn (the last one from then on),
// keeping each request it read.
class ScriptedHttpServer {
  public:
    explicit ScriptedHttpServer(std::string response)
        : ScriptedHttpServer(std::vector<std::string>{std::move(response)}) {}
    explicit ScriptedHttpServer(std::vector<std::string> responses)
        : responses_(std::move(responses)), thread_([this] { Serve(); }) {}
    ~ScriptedHttpServer() {
        ::shutdown(listener_.fd(), SHUT_RDWR);  // wakes accept()
        thread_.join();
    }

    int port() const { return listener_.port(); }
    std::vector<std::string> requests() const {
        std::lock_guard<std::mutex> lock(mutex_);
        return requests_;
    }

  private:
    void Serve() {
        for (;;) {
            const int fd = ::accept(listener_.fd(), nullptr, nullptr);
            if (fd < 0) return;
            std::string request = ReadHttpRequest(fd);
            std::string response;
            {
                std::lock_guard<std::mutex> lock(mutex_);
                response = responses_[std::min(requests_.size(), responses_.size() - 1)];
                requests_.push_back(std::move(request));
            }
            // MSG_NOSIGNAL: a client that stops reading (a capped body) is no SIGPIPE.
            std::size_t sent = 0;
            while (sent < response.size()) {
                const ssize_t n =
                    ::send(fd, response.data() + sent, response.size() - sent, MSG_NOSIGNAL);
                if (n <= 0) break;
                sent += static_cast<std::size_t>(n);
            }
            ::close(fd);
        }
    }

    LoopbackListener listener_;
    std::vector<std::string> responses_;
    mutable std::mutex mutex_;
    std::vector<std::string> requests_;
    std::thread thread_;
};

inline std::string Response(const std::string& status_line, const std::string& body) {
    return absl::StrCat("HTTP/1.1 ", status_line, "\r\nContent-Type: text/plain\r\n",
                        "Content-Length: ", body.size(), "\r\n\r\n", body);
}

}  // namespace soilvol::server::testing_http
