#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "google/protobuf/message.h"
#include "server/http/http_server.hpp"

namespace soilvol::server {

/// One Server-Sent Events response over an exchange: each message as `id:` (its `id_field`),
/// `event: <event>`, `data:` its proto3 JSON; a null message as a `: keepalive` comment; the
/// end as an `error` event carrying the google.rpc.Status of why the server ended it. Messages
/// that arrive before Start sent the head wait, in order. Safe from any thread.
class SseStream {
  public:
    SseStream(std::shared_ptr<HttpExchange> exchange, std::string event, std::string id_field);

    /// Queues one message (null: a heartbeat). False once the client is gone.
    bool Deliver(const google::protobuf::Message* message);
    /// The `error` event, then the end of the response.
    void End(const absl::Status& status);
    /// Sends `head` (as text/event-stream, not cached, not buffered by proxies), the retry hint
    /// and what waited. False when the client left already.
    bool Start(HttpResponse head);

  private:
    bool Send(std::string chunk);

    const std::shared_ptr<HttpExchange> exchange_;
    const std::string event_;
    const std::string id_field_;
    std::mutex mutex_;
    bool started_ = false;
    std::vector<std::string> pending_;
};

}  // namespace soilvol::server
