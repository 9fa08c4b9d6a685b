#include "server/webhooks/webhook_post.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <algorithm>
#include <boost/asio/ip/address.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <optional>
#include <string_view>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/base/absl_view.hpp"

namespace soilvol::server {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace ssl = asio::ssl;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;
using HeaderList = std::vector<std::pair<std::string, std::string>>;

constexpr const char* kUserAgent = "soilvol-webhooks/1";

// One call's I/O: its own io_context, and the deadline of the whole exchange. The context is
// the first member, so it outlives every object that queued a handler on it.
struct PostExchange {
    PostExchange(const PostOptions& post_options, PostResult& post_result)
        : options(post_options),
          result(post_result),
          deadline(Clock::now() + post_options.timeout) {}

    asio::io_context context;
    tcp::resolver resolver{context};
    asio::steady_timer resolve_timer{context};
    bool resolve_timed_out = false;
    const PostOptions& options;
    PostResult& result;
    Clock::time_point deadline;
};

// Starts an operation through `start(handler)` and runs the context until it completes; its
// error code (would_block if the context ran out of work first, which cannot happen).
template <class Start>
beast::error_code Await(asio::io_context& context, Start&& start) {
    beast::error_code error = asio::error::would_block;
    bool done = false;
    start([&error, &done](beast::error_code ec, auto&&...) {
        error = ec;
        done = true;
    });
    context.restart();
    while (!done && context.run_one() > 0) {
    }
    return error;
}

// Records a failed step: "<step>: <reason>", or the timeout when the deadline is behind.
void Fail(PostExchange& exchange, std::string_view step, const beast::error_code& ec) {
    if (ec == beast::error::timeout || Clock::now() >= exchange.deadline) {
        exchange.result.error =
            absl::StrCat("timeout after ", exchange.options.timeout.count(), " ms");
    } else {
        exchange.result.error = absl::StrCat(AbslView(step), ": ", ec.message());
    }
}

// RFC 7230 token characters for a header name; a value without CR, LF or NUL; none of the
// headers that frame the message or that PostJson sets for the connection.
std::string CheckHeaders(const HeaderList& headers) {
    static constexpr std::string_view kTokenPunctuation = "!#$%&'*+-.^_`|~";
    for (const auto& [name, value] : headers) {
        const bool name_ok = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
            return absl::ascii_isalnum(static_cast<unsigned char>(c)) ||
                   kTokenPunctuation.find(c) != std::string_view::npos;
        });
        if (!name_ok) return "header: a name is not an HTTP token";
        if (value.find_first_of(std::string_view("\r\n\0", 3)) != std::string::npos) {
            return absl::StrCat("header: the value of ", name, " has CR, LF or NUL");
        }
        for (const char* reserved : {"host", "content-length", "transfer-encoding", "connection"}) {
            if (absl::EqualsIgnoreCase(name, reserved)) {
                return absl::StrCat("header: ", name, " is set by the client");
            }
        }
    }
    return "";
}

http::request<http::string_body> MakeRequest(const WebhookUrl& url, const HeaderList& headers,
                                             const std::string& body) {
    http::request<http::string_body> request{http::verb::post, url.target, 11};
    request.set(http::field::host, HostHeaderOf(url));
    request.set(http::field::user_agent, kUserAgent);
    request.set(http::field::content_type, "application/json");
    request.set(http::field::connection, "close");
    for (const auto& [name, value] : headers) request.set(name, value);
    request.body() = body;
    request.prepare_payload();
    return request;
}

// The host's addresses, within the deadline (a resolver blocked in getaddrinfo is waited for).
std::optional<tcp::resolver::results_type> Resolve(PostExchange& exchange, const WebhookUrl& url) {
    exchange.resolve_timer.expires_at(exchange.deadline);
    exchange.resolve_timer.async_wait([&exchange](beast::error_code ec) {
        if (ec) return;
        exchange.resolve_timed_out = true;
        exchange.resolver.cancel();
    });
    tcp::resolver::results_type endpoints;
    const beast::error_code ec = Await(exchange.context, [&](auto handler) {
        exchange.resolver.async_resolve(
            url.host, url.port, tcp::resolver::numeric_service,
            [&endpoints, handler](beast::error_code e, tcp::resolver::results_type found) mutable {
                endpoints = std::move(found);
                handler(e);
            });
    });
    exchange.resolve_timer.cancel();
    if (exchange.resolve_timed_out) {
        Fail(exchange, "resolve", beast::error::timeout);
        return std::nullopt;
    }
    if (ec) {
        Fail(exchange, "resolve", ec);
        return std::nullopt;
    }
    return endpoints;
}

bool Connect(PostExchange& exchange, beast::tcp_stream& stream,
             const tcp::resolver::results_type& endpoints) {
    stream.expires_at(exchange.deadline);
    const beast::error_code ec =
        Await(exchange.context, [&](auto handler) { stream.async_connect(endpoints, handler); });
    if (ec) Fail(exchange, "connect", ec);
    return !ec;
}

// Writes the request and reads the response, at most max_response_bytes of body.
template <class Stream>
void Exchange(PostExchange& exchange, Stream& stream,
              const http::request<http::string_body>& request) {
    beast::error_code ec =
        Await(exchange.context, [&](auto handler) { http::async_write(stream, request, handler); });
    if (ec) return Fail(exchange, "write", ec);
    beast::flat_buffer buffer;
    http::response_parser<http::string_body> parser;
    parser.body_limit(exchange.options.max_response_bytes);
    // The header alone first: Beast 1.74's eager body parsing forgets a Content-Length over
    // the limit (finish_header's error is reset by the body's init).
    ec = Await(exchange.context,
               [&](auto handler) { http::async_read_header(stream, buffer, parser, handler); });
    if (!ec && !parser.is_done()) {
        ec = Await(exchange.context,
                   [&](auto handler) { http::async_read(stream, buffer, parser, handler); });
    }
    // A TLS peer that closes without close_notify ends a body delimited by the connection's end.
    if (ec == ssl::error::stream_truncated && parser.is_header_done()) parser.put_eof(ec);
    if (parser.is_header_done()) {
        exchange.result.status_code = parser.get().result_int();
        exchange.result.body_excerpt = parser.get().body().substr(0, kBodyExcerptBytes);
    }
    if (ec == http::error::body_limit) {
        exchange.result.error = absl::StrCat("read: response body over ",
                                             exchange.options.max_response_bytes, " bytes");
    } else if (ec) {
        Fail(exchange, "read", ec);
    }
}

// The client's TLS: 1.2 or later, the peer verified against ca_file or the system's CAs.
bool ConfigureTls(PostExchange& exchange, ssl::context& tls) {
    SSL_CTX_set_min_proto_version(tls.native_handle(), TLS1_2_VERSION);
    beast::error_code ec;
    const std::string& ca_file = exchange.options.ca_file;
    if (ca_file.empty()) {
        tls.set_default_verify_paths(ec);
    } else if (std::FILE* file = std::fopen(ca_file.c_str(), "r"); file == nullptr) {
        // OpenSSL's reason for a missing file is "system lib": errno says more.
        exchange.result.error =
            absl::StrCat("tls: cannot read ", ca_file, ": ", std::strerror(errno));
        return false;
    } else {
        std::fclose(file);
        tls.load_verify_file(ca_file, ec);
    }
    if (!ec) tls.set_verify_mode(ssl::verify_peer, ec);
    if (ec) {
        // asio reports "asio.ssl error"; OpenSSL's reason names it.
        const char* reason = ERR_reason_error_string(static_cast<unsigned long>(ec.value()));
        exchange.result.error =
            absl::StrCat("tls: cannot load ", ca_file.empty() ? "the system's CAs" : ca_file, ": ",
                         reason != nullptr ? reason : ec.message().c_str());
    }
    return !ec;
}

// ssl::host_name_verification, whose refusal OpenSSL would report as "unspecified": named
// here as OpenSSL's own host check names it.
class NamedHostVerification {
  public:
    explicit NamedHostVerification(const std::string& host) : check_(host) {
        beast::error_code not_an_address;
        asio::ip::make_address(host, not_an_address);
        address_ = !not_an_address;
    }
    bool operator()(bool preverified, ssl::verify_context& context) const {
        if (check_(preverified, context)) return true;
        X509_STORE_CTX* store = context.native_handle();
        if (X509_STORE_CTX_get_error(store) == X509_V_OK) {
            X509_STORE_CTX_set_error(
                store, address_ ? X509_V_ERR_IP_ADDRESS_MISMATCH : X509_V_ERR_HOSTNAME_MISMATCH);
        }
        return false;
    }

  private:
    ssl::host_name_verification check_;
    bool address_ = false;
};

std::string HandshakeError(beast::ssl_stream<beast::tcp_stream>& stream,
                           const beast::error_code& ec) {
    const long verify = SSL_get_verify_result(stream.native_handle());
    if (verify != X509_V_OK) {
        return absl::StrCat("tls: certificate verify failed: ",
                            X509_verify_cert_error_string(verify));
    }
    return absl::StrCat("tls: ", ec.message());
}

void PostOverTls(PostExchange& exchange, const WebhookUrl& url,
                 const tcp::resolver::results_type& endpoints,
                 const http::request<http::string_body>& request) {
    ssl::context tls(ssl::context::tls_client);
    if (!ConfigureTls(exchange, tls)) return;
    beast::ssl_stream<beast::tcp_stream> stream(exchange.context, tls);
    // SNI names a host, never an address (RFC 6066, Sec. 3).
    beast::error_code not_an_address;
    asio::ip::make_address(url.host, not_an_address);
    // SSL_set_tlsext_host_name without its macro's C cast.
    if (not_an_address &&
        SSL_ctrl(stream.native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name,
                 const_cast<char*>(url.host.c_str())) != 1) {
        exchange.result.error = "tls: cannot set the server name";
        return;
    }
    stream.set_verify_callback(NamedHostVerification(url.host));
    if (!Connect(exchange, beast::get_lowest_layer(stream), endpoints)) return;
    const beast::error_code ec = Await(exchange.context, [&](auto handler) {
        stream.async_handshake(ssl::stream_base::client, handler);
    });
    if (ec == beast::error::timeout || (ec && Clock::now() >= exchange.deadline)) {
        return Fail(exchange, "tls", ec);
    }
    if (ec) {
        exchange.result.error = HandshakeError(stream, ec);
        return;
    }
    Exchange(exchange, stream, request);
}

void PostPlain(PostExchange& exchange, const tcp::resolver::results_type& endpoints,
               const http::request<http::string_body>& request) {
    beast::tcp_stream stream(exchange.context);
    if (!Connect(exchange, stream, endpoints)) return;
    Exchange(exchange, stream, request);
}

void PostOnce(const WebhookUrl& url, const HeaderList& headers, const std::string& body,
              const PostOptions& options, PostResult& result) {
    if (std::string error = CheckHeaders(headers); !error.empty()) {
        result.error = std::move(error);
        return;
    }
    PostExchange exchange(options, result);
    const std::optional<tcp::resolver::results_type> endpoints = Resolve(exchange, url);
    if (!endpoints) return;
    const http::request<http::string_body> request = MakeRequest(url, headers, body);
    if (url.tls) {
        PostOverTls(exchange, url, *endpoints, request);
    } else {
        PostPlain(exchange, *endpoints, request);
    }
}

}  // namespace

PostResult PostJson(const WebhookUrl& url, const HeaderList& headers, const std::string& body,
                    const PostOptions& options) {
    const Clock::time_point start = Clock::now();
    PostResult result;
    try {
        PostOnce(url, headers, body, options, result);
    } catch (const std::exception& e) {
        result.error = absl::StrCat("internal: ", e.what());
    } catch (...) {
        result.error = "internal: unknown exception";
    }
    result.latency = std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - start);
    return result;
}

}  // namespace soilvol::server
