#pragma once

#include <chrono>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "server/webhooks/webhook_url.hpp"

namespace soilvol::server {

/// The most of a response body a PostResult keeps [bytes].
inline constexpr std::size_t kBodyExcerptBytes = 512;

/// What one POST came to.
struct PostResult {
    int status_code = 0;                   ///< the response's status; 0 when no response came
    std::string error;                     ///< "" when a whole response came, else what went wrong
    std::string body_excerpt;              ///< the first kBodyExcerptBytes of the response body
    std::chrono::milliseconds latency{0};  ///< the whole call
};

struct PostOptions {
    std::chrono::milliseconds timeout{5000};  ///< resolve, connect, TLS, write and read together
    std::string ca_file;                      ///< PEM certificates to trust; "" = the system's
    std::size_t max_response_bytes = 65536;   ///< a longer response body is an error
};

/// POSTs `body` as application/json to `url` over HTTP/1.1 (https: SNI, the peer's certificate
/// and host name verified) with Host, Content-Type, Content-Length, User-Agent
/// (soilvol-webhooks/1), Connection: close and `headers`, and reads the response. Redirects are
/// not followed. Never throws: failures are in `error` ("resolve: ...", "connect: ...",
/// "tls: ...", "write: ...", "read: ...", "timeout after <n> ms", "header: ..." for a header
/// name that is not a token, a value with CR, LF or NUL, or one of the framing headers above);
/// a response body over the limit is an error that keeps the status code. Blocking, with its
/// own io_context: safe to call from any number of threads.
PostResult PostJson(const WebhookUrl& url,
                    const std::vector<std::pair<std::string, std::string>>& headers,
                    const std::string& body, const PostOptions& options);

}  // namespace soilvol::server
