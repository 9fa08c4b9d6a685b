#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace soilvol::server {

/// Header fields of one request or response, in arrival order; names compare case-blind.
class HttpHeaders {
  public:
    void Add(std::string name, std::string value);
    /// Replaces every field called `name`.
    void Set(const std::string& name, std::string value);
    /// The first value of `name`, "" when absent.
    const std::string& Get(std::string_view name) const;
    bool Has(std::string_view name) const;
    const std::vector<std::pair<std::string, std::string>>& fields() const { return fields_; }

  private:
    std::vector<std::pair<std::string, std::string>> fields_;
};

/// One request. `head` checks see everything but the body; handlers get the body too.
struct HttpRequest {
    std::string method;  ///< "GET", "POST", ...
    std::string target;  ///< as sent: "/v1/containers?page_size=10"
    std::string path;    ///< target up to '?', not percent-decoded
    std::string query;   ///< after '?', "" when none
    HttpHeaders headers;
    std::string body;
    std::optional<std::uint64_t> content_length;  ///< declared; nullopt for chunked or none
    bool chunked = false;
    std::string peer;          ///< "10.0.0.7:51234"
    std::string tls_identity;  ///< the verified client certificate's subject (mTLS), else ""
    bool tls = false;
};

struct HttpResponse {
    int status = 200;
    HttpHeaders headers;
    std::string content_type = "application/json";
    std::string body;
};

/// The answer channel of one request, shared with the work it started (any thread).
class HttpExchange {
  public:
    virtual ~HttpExchange() = default;
    /// Sends the response; only the first call counts. Safe from any thread.
    virtual void Respond(HttpResponse response) = 0;
    /// True once the client closed its side of the connection, or the exchange was answered
    /// (for example by RespondBy's fallback): the work can stop.
    virtual bool Gone() const = 0;
    /// Sends `fallback` at `when` unless a response was sent before (the caller's deadline).
    virtual void RespondBy(std::chrono::steady_clock::time_point when, HttpResponse fallback) = 0;

    /// A streamed response (Server-Sent Events, say) instead of Respond: the status and headers
    /// of `head` now, with chunked transfer encoding and no deadline between chunks; then each
    /// Send as one chunk, in order; Finish ends it. False when the exchange was answered or
    /// the client is gone. Safe from any thread.
    virtual bool StartStream(HttpResponse head) = 0;
    /// Queues `chunk` (empty ones are skipped). False once the stream is over or the client is
    /// gone; a client that falls kStreamBacklogBytes behind is disconnected (an SSE client
    /// reconnects with its Last-Event-ID).
    virtual bool Send(std::string chunk) = 0;
    /// Ends the stream (the last chunk); the connection then serves its next request.
    virtual void Finish() = 0;
    /// Send for a producer that may wait (a worker streaming a download): first waits, up to
    /// `deadline`, while more than kPacedBacklogBytes are unsent, so that a slow reader slows
    /// the producer instead of being cut off or growing the queue. False when the client is
    /// gone, the deadline passed or the stream is over.
    virtual bool SendPaced(std::string chunk, std::chrono::steady_clock::time_point deadline) = 0;
    /// Ends a stream without its last chunk (the connection closes): a download that failed
    /// half way shows as cut short, not as complete.
    virtual void Abort() = 0;
};

/// What SendPaced lets wait unsent before it waits.
inline constexpr std::size_t kPacedBacklogBytes = 256 * 1024;

/// What a streamed response may hold unsent for a slow reader before it is cut off.
inline constexpr std::size_t kStreamBacklogBytes = 1 << 20;

/// A response of `status` whose body is `body` (JSON).
HttpResponse JsonResponse(int status, std::string body);

}  // namespace soilvol::server
