#include "server/http_server.hpp"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <poll.h>

#include <algorithm>
#include <array>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <deque>
#include <limits>
#include <mutex>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "server/logging.hpp"
#include "server/status_map.hpp"
#include "server/store/absl_view.hpp"
#include "server/watched_file.hpp"

namespace soilvol::server {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
namespace ssl = net::ssl;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using PlainStream = beast::tcp_stream;
using TlsStream = beast::ssl_stream<beast::tcp_stream>;

const std::string kEmpty;
// Read and dropped before closing on a refusal, so that a client still sending its body reads
// the answer instead of a reset: what it announced (at least 1 MiB), within 5 s.
constexpr std::uint64_t kMinDrainBytes = 1 << 20;
constexpr std::chrono::seconds kDrainTime{5};

// ---------------------------------------------------------------------------------------------
// TLS: a context built from the files, built again when they change.

// "--tls-cert /etc/tls.crt: no start line" from the error OpenSSL reported.
absl::Status TlsFileError(const char* flag, const std::string& path,
                          const boost::system::system_error& e) {
    const char* reason = ERR_reason_error_string(static_cast<unsigned long>(e.code().value()));
    return absl::InvalidArgumentError(absl::StrCat(
        flag, " ", path, ": ", reason != nullptr ? reason : e.code().message().c_str()));
}

absl::StatusOr<std::shared_ptr<ssl::context>> BuildTlsContext(const TlsFiles& files) {
    auto context = std::make_shared<ssl::context>(ssl::context::tls_server);
    context->set_options(ssl::context::default_workarounds | ssl::context::no_sslv2 |
                         ssl::context::no_sslv3 | ssl::context::no_tlsv1 |
                         ssl::context::no_tlsv1_1 | ssl::context::single_dh_use);
    try {
        context->use_certificate_chain_file(files.cert_path);
    } catch (const boost::system::system_error& e) {
        return TlsFileError("--tls-cert", files.cert_path, e);
    }
    try {
        context->use_private_key_file(files.key_path, ssl::context::pem);
    } catch (const boost::system::system_error& e) {
        return TlsFileError("--tls-key", files.key_path, e);
    }
    if (SSL_CTX_check_private_key(context->native_handle()) != 1) {
        return absl::InvalidArgumentError(absl::StrCat(
            "--tls-key ", files.key_path, ": does not match the certificate in ", files.cert_path));
    }
    if (!files.client_ca_path.empty()) {
        try {
            context->load_verify_file(files.client_ca_path);
        } catch (const boost::system::system_error& e) {
            return TlsFileError("--tls-client-ca", files.client_ca_path, e);
        }
        context->set_verify_mode(ssl::verify_peer | ssl::verify_fail_if_no_peer_cert);
    }
    return context;
}

class TlsContextSource {
  public:
    explicit TlsContextSource(TlsFiles files)
        : files_(std::move(files)),
          watched_({files_.cert_path, files_.key_path, files_.client_ca_path}) {}

    absl::Status Load() {
        watched_.Mark();
        absl::StatusOr<std::shared_ptr<ssl::context>> context = Build();
        if (!context.ok()) return context.status();
        context_ = *std::move(context);
        return absl::OkStatus();
    }

    /// The context for a new connection: rebuilt when a file changed (looked at no more than
    /// once a second); a rebuild that fails (a rotation half done) keeps the previous one and
    /// is logged once per change of the files.
    std::shared_ptr<ssl::context> Current() {
        std::lock_guard<std::mutex> lock(mutex_);
        if (watched_.Changed()) {
            watched_.Mark();
            absl::StatusOr<std::shared_ptr<ssl::context>> context = Build();
            if (context.ok()) {
                context_ = *std::move(context);
                LogEvent(LogLevel::kInfo, "tls files reloaded", {});
            } else {
                LogEvent(LogLevel::kError, "tls files not reloaded",
                         {{"error", context.status().message()}});
            }
        }
        return context_;
    }

  private:
    absl::StatusOr<std::shared_ptr<ssl::context>> Build() const { return BuildTlsContext(files_); }

    const TlsFiles files_;
    std::mutex mutex_;
    WatchedFiles watched_;
    std::shared_ptr<ssl::context> context_;
};

std::string SubjectOf(SSL* ssl) {
    X509* cert = SSL_get_peer_certificate(ssl);
    if (cert == nullptr) return "";
    std::string subject;
    BIO* bio = BIO_new(BIO_s_mem());
    if (bio != nullptr &&
        X509_NAME_print_ex(bio, X509_get_subject_name(cert), 0, XN_FLAG_RFC2253) >= 0) {
        char* data = nullptr;
        const long size = BIO_get_mem_data(bio, &data);
        if (size > 0) subject.assign(data, static_cast<std::size_t>(size));
    }
    BIO_free(bio);
    X509_free(cert);
    return subject;
}

// ---------------------------------------------------------------------------------------------
// Shared state of the server, seen by every connection.

struct Shared {
    HttpServerOptions options;
    HttpServer::Admit admit;
    HttpServer::Handle handle;
    HttpConnectionStats stats;
    std::unique_ptr<TlsContextSource> tls;

    bool Reserve(std::uint64_t bytes) {
        std::int64_t held = stats.inflight_body.load();
        const auto limit = static_cast<std::int64_t>(options.limits.max_inflight_body_bytes);
        do {
            if (held + static_cast<std::int64_t>(bytes) > limit) return false;
        } while (!stats.inflight_body.compare_exchange_weak(
            held, held + static_cast<std::int64_t>(bytes)));
        return true;
    }
    void Release(std::uint64_t bytes) { stats.inflight_body -= static_cast<std::int64_t>(bytes); }
};

/// Body bytes a request holds against max_inflight_body_bytes, given back when it is freed.
class BodyReservation {
  public:
    explicit BodyReservation(std::shared_ptr<Shared> shared) : shared_(std::move(shared)) {}
    ~BodyReservation() { shared_->Release(bytes_); }
    BodyReservation(const BodyReservation&) = delete;
    BodyReservation& operator=(const BodyReservation&) = delete;
    /// Grows the reservation to `total` bytes; false when the budget has no room.
    bool GrowTo(std::uint64_t total) {
        if (total <= bytes_) return true;
        if (!shared_->Reserve(total - bytes_)) return false;
        bytes_ = total;
        return true;
    }

  private:
    std::shared_ptr<Shared> shared_;
    std::uint64_t bytes_ = 0;
};

HttpResponse ErrorResponse(int status, const absl::Status& error) {
    HttpResponse response;
    response.status = status;
    response.body = ErrorJson(error);
    if (const int seconds = RetryAfterSeconds(error); seconds > 0) {
        response.headers.Set("Retry-After", std::to_string(seconds));
    }
    return response;
}

HttpResponse ErrorResponse(int status, absl::StatusCode code, const std::string& message) {
    absl::Status error(code, message);
    // Too large stays too large: no retry hint.
    if (status == 413) error = WithReason(std::move(error), kReasonTooLarge);
    return ErrorResponse(status, error);
}

HttpResponse UploadBudgetFull() {
    return ErrorResponse(
        429,
        WithReason(absl::ResourceExhaustedError("server busy receiving other uploads; retry later"),
                   "UPLOAD_BUDGET_FULL"));
}

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

// ---------------------------------------------------------------------------------------------
// One connection: read a request within the limits, admit it, read its body, hand it over,
// write the answer, and again while the client keeps the connection.

template <typename Stream>
class Connection;

template <typename Stream>
class Exchange final : public HttpExchange, public std::enable_shared_from_this<Exchange<Stream>> {
  public:
    Exchange(std::shared_ptr<Connection<Stream>> connection, int fd,
             std::shared_ptr<std::atomic<bool>> closed, std::unique_ptr<BodyReservation> body)
        : connection_(std::move(connection)),
          fd_(fd),
          closed_(std::move(closed)),
          body_(std::move(body)) {}

    bool StartStream(HttpResponse head) override {
        if (answered_.exchange(true)) return false;
        body_.reset();
        std::shared_ptr<Connection<Stream>> connection = Current();
        if (!connection || *closed_) return false;
        streaming_ = true;
        connection->PostStreamHead(std::move(head));
        return true;
    }

    bool Send(std::string chunk) override {
        if (!streaming_ || finished_ || *closed_) return false;
        if (chunk.empty()) return true;
        std::shared_ptr<Connection<Stream>> connection = Current();
        if (!connection) return false;
        connection->PostStreamChunk(std::move(chunk), false);
        return true;
    }

    void Finish() override {
        if (!streaming_ || finished_.exchange(true)) return;
        std::shared_ptr<Connection<Stream>> connection;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            connection = std::move(connection_);
        }
        if (connection) connection->PostStreamChunk({}, true);
    }

    void Respond(HttpResponse response) override {
        if (answered_.exchange(true)) return;
        body_.reset();
        std::shared_ptr<Connection<Stream>> connection;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            connection = std::move(connection_);
        }
        if (connection) connection->PostResponse(std::move(response));
    }

    void RespondBy(Clock::time_point when, HttpResponse fallback) override {
        std::shared_ptr<Connection<Stream>> connection;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            connection = connection_;
        }
        if (connection)
            connection->ArmDeadline(when, this->shared_from_this(), std::move(fallback));
    }

    bool Gone() const override {
        if ((answered_ && !streaming_) || finished_ || *closed_) return true;
        pollfd watch{fd_, POLLRDHUP, 0};
        return ::poll(&watch, 1, 0) > 0 && (watch.revents & (POLLRDHUP | POLLHUP | POLLERR)) != 0;
    }

  private:
    std::shared_ptr<Connection<Stream>> Current() {
        std::lock_guard<std::mutex> lock(mutex_);
        return connection_;
    }

    std::mutex mutex_;
    std::shared_ptr<Connection<Stream>> connection_;  ///< kept open until the answer is sent
    const int fd_;
    std::shared_ptr<std::atomic<bool>> closed_;
    std::unique_ptr<BodyReservation> body_;
    std::atomic<bool> answered_{false};
    std::atomic<bool> streaming_{false};
    std::atomic<bool> finished_{false};
};

template <typename Stream>
class Connection : public std::enable_shared_from_this<Connection<Stream>> {
  public:
    template <typename... Args>
    Connection(std::shared_ptr<Shared> shared, std::string peer, Args&&... stream_args)
        : shared_(std::move(shared)),
          stream_(std::forward<Args>(stream_args)...),
          buffer_(shared_->options.limits.max_header_bytes + 64 * 1024),
          deadline_(stream_.get_executor()),
          peer_(std::move(peer)) {
        ++shared_->stats.open;
    }
    ~Connection() { --shared_->stats.open; }

    void Start() {
        if constexpr (std::is_same_v<Stream, TlsStream>) {
            Lowest().expires_after(shared_->options.limits.header_timeout);
            stream_.async_handshake(
                ssl::stream_base::server,
                [self = this->shared_from_this()](beast::error_code ec) { self->OnHandshake(ec); });
        } else {
            WaitForRequest();
        }
    }

    /// The TLS context the stream was made from, kept as long as the connection.
    void KeepContext(std::shared_ptr<ssl::context> context) { context_ = std::move(context); }

    /// At `when`, unless answered before, `exchange` answers `fallback`.
    void ArmDeadline(Clock::time_point when, std::shared_ptr<HttpExchange> exchange,
                     HttpResponse fallback) {
        net::post(stream_.get_executor(),
                  [self = this->shared_from_this(), when, exchange = std::move(exchange),
                   fallback = std::move(fallback)]() mutable {
                      self->deadline_.expires_at(when);
                      self->deadline_.async_wait(
                          [exchange = std::move(exchange),
                           fallback = std::move(fallback)](beast::error_code ec) mutable {
                              if (!ec) exchange->Respond(std::move(fallback));
                          });
                  });
    }

    void PostStreamHead(HttpResponse head) {
        net::post(stream_.get_executor(),
                  [self = this->shared_from_this(), head = std::move(head)]() mutable {
                      self->WriteStreamHead(std::move(head));
                  });
    }

    /// One chunk of a streamed response, or its end (`last`).
    void PostStreamChunk(std::string chunk, bool last) {
        net::post(stream_.get_executor(),
                  [self = this->shared_from_this(), chunk = std::move(chunk), last]() mutable {
                      self->QueueChunk(std::move(chunk), last);
                  });
    }

    void PostResponse(HttpResponse response) {
        net::post(stream_.get_executor(),
                  [self = this->shared_from_this(), response = std::move(response)]() mutable {
                      self->Write(std::move(response));
                  });
    }

  private:
    const HttpLimits& limits() const { return shared_->options.limits; }
    beast::tcp_stream& Lowest() { return beast::get_lowest_layer(stream_); }

    void OnHandshake(beast::error_code ec) {
        if (ec) {
            ++shared_->stats.tls_failures;
            return Close();
        }
        if constexpr (std::is_same_v<Stream, TlsStream>) {
            tls_identity_ = SubjectOf(stream_.native_handle());
        }
        WaitForRequest();
    }

    // Keep-alive: wait for the first byte of the next request, then give the header its time.
    void WaitForRequest() {
        if (buffer_.size() > 0) return ReadHeader();
        Lowest().expires_after(limits().idle_timeout);
        stream_.async_read_some(
            buffer_.prepare(4096),
            [self = this->shared_from_this()](beast::error_code ec, std::size_t bytes) {
                if (ec == beast::error::timeout) ++self->shared_->stats.timed_out;
                if (ec) return self->Close();
                self->buffer_.commit(bytes);
                self->ReadHeader();
            });
    }

    void ReadHeader() {
        close_after_ = false;
        parser_.emplace();
        parser_->header_limit(static_cast<std::uint32_t>(limits().max_header_bytes));
        // The declared length is judged after the header (OnHeader), so that the refusal can
        // drain what the client still sends; the limit itself guards chunked bodies.
        parser_->body_limit(std::numeric_limits<std::uint64_t>::max());
        Lowest().expires_after(limits().header_timeout);
        http::async_read_header(stream_, buffer_, *parser_,
                                [self = this->shared_from_this()](
                                    beast::error_code ec, std::size_t) { self->OnHeader(ec); });
    }

    void OnHeader(beast::error_code ec) {
        if (ec == beast::error::timeout) {
            ++shared_->stats.timed_out;
            return Close();
        }
        if (ec == http::error::end_of_stream || ec == net::error::eof ||
            ec == net::error::connection_reset) {
            return Close();
        }
        if (ec == http::error::header_limit || ec == http::error::buffer_overflow) {
            return Refuse(431, absl::StatusCode::kInvalidArgument, "request header too large");
        }
        if (ec == http::error::body_limit) {
            return Refuse(413, absl::StatusCode::kResourceExhausted,
                          absl::StrCat("request body exceeds the limit of ",
                                       limits().max_body_bytes, " bytes"));
        }
        if (ec) return Refuse(400, absl::StatusCode::kInvalidArgument, "malformed HTTP request");
        head_ = HeadOf(parser_->get());
        drain_budget_ = std::max<std::uint64_t>(
            kMinDrainBytes, std::min<std::uint64_t>(head_.content_length.value_or(0) + 65536,
                                                    4 * limits().max_body_bytes + 65536));
        keep_alive_ = parser_->get().keep_alive();
        version_ = parser_->get().version();
        const bool has_body = head_.chunked || head_.content_length.value_or(0) > 0;
        if (head_.content_length.value_or(0) > limits().max_body_bytes) {
            return Refuse(413, absl::StatusCode::kResourceExhausted,
                          absl::StrCat("request body exceeds the limit of ",
                                       limits().max_body_bytes, " bytes"));
        }
        parser_->body_limit(limits().max_body_bytes);
        if (std::optional<HttpResponse> refusal = shared_->admit(head_)) {
            close_after_ = has_body;
            return Write(std::move(*refusal));
        }
        body_ = std::make_unique<BodyReservation>(shared_);
        if (!body_->GrowTo(head_.content_length.value_or(0))) {
            close_after_ = has_body;
            return Write(UploadBudgetFull());
        }
        if (!has_body) return Dispatch();
        body_started_ = Clock::now();
        if (absl::EqualsIgnoreCase(head_.headers.Get("Expect"), "100-continue")) {
            auto go_on = std::make_shared<http::response<http::empty_body>>(
                http::status::continue_, parser_->get().version());
            Lowest().expires_after(limits().write_timeout);
            return http::async_write(
                stream_, *go_on,
                [self = this->shared_from_this(), go_on](beast::error_code write_ec, std::size_t) {
                    if (write_ec) return self->Close();
                    self->ReadBody();
                });
        }
        ReadBody();
    }

    void ReadBody() {
        if (parser_->is_done()) return Dispatch();
        Lowest().expires_after(limits().body_stall_timeout);
        http::async_read_some(stream_, buffer_, *parser_,
                              [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
                                  self->OnBody(ec);
                              });
    }

    void OnBody(beast::error_code ec) {
        if (ec == beast::error::timeout) {  // the stream closed itself: no answer can go out
            ++shared_->stats.timed_out;
            return Close();
        }
        if (ec == http::error::body_limit) {
            return Refuse(413, absl::StatusCode::kResourceExhausted,
                          absl::StrCat("request body exceeds the limit of ",
                                       limits().max_body_bytes, " bytes"));
        }
        if (ec == http::error::end_of_stream || ec == net::error::eof ||
            ec == net::error::connection_reset) {
            return Close();
        }
        if (ec)
            return Refuse(400, absl::StatusCode::kInvalidArgument, "malformed HTTP request body");
        const std::uint64_t received = parser_->get().body().size();
        if (!body_->GrowTo(received)) {
            close_after_ = true;
            return Write(UploadBudgetFull());
        }
        const double seconds = std::chrono::duration<double>(Clock::now() - body_started_).count();
        if (Clock::now() - body_started_ > limits().body_grace &&
            static_cast<double>(received) < seconds * limits().min_body_rate_bytes_s) {
            ++shared_->stats.timed_out;
            return Refuse(408, absl::StatusCode::kDeadlineExceeded,
                          absl::StrCat("request body: arriving slower than ",
                                       limits().min_body_rate_bytes_s, " bytes/s"));
        }
        ReadBody();
    }

    void Dispatch() {
        HttpRequest request = std::move(head_);
        request.body = std::move(parser_->get().body());
        parser_.reset();
        Lowest().expires_never();
        auto exchange = std::make_shared<Exchange<Stream>>(
            this->shared_from_this(), Lowest().socket().native_handle(), closed_, std::move(body_));
        shared_->handle(std::move(request), std::move(exchange));
    }

    HttpRequest HeadOf(const http::request<http::string_body>& message) const {
        HttpRequest head;
        head.method = std::string(message.method_string());
        head.target = std::string(message.target());
        const std::size_t question = head.target.find('?');
        head.path = head.target.substr(0, question);
        if (question != std::string::npos) head.query = head.target.substr(question + 1);
        for (const auto& field : message) {
            head.headers.Add(std::string(field.name_string()), std::string(field.value()));
        }
        head.content_length = parser_->content_length()
                                  ? std::optional<std::uint64_t>(*parser_->content_length())
                                  : std::nullopt;
        head.chunked = parser_->chunked();
        head.peer = peer_;
        head.tls = std::is_same_v<Stream, TlsStream>;
        head.tls_identity = tls_identity_;
        return head;
    }

    // An error before the request was read through: answer, then close.
    void Refuse(int status, absl::StatusCode code, const std::string& message) {
        close_after_ = true;
        if (!version_) version_ = 11;
        Write(ErrorResponse(status, code, message));
    }

    void Write(HttpResponse response) {
        if (*closed_) return;
        deadline_.cancel();
        auto message = std::make_shared<http::response<http::string_body>>();
        message->version(version_ == 0 ? 11 : version_);
        message->result(static_cast<unsigned>(response.status));
        for (const auto& [name, value] : response.headers.fields()) message->set(name, value);
        if (!response.body.empty() || response.status != 204) {
            message->set(http::field::content_type, response.content_type);
        }
        message->body() = std::move(response.body);
        message->keep_alive(keep_alive_ && !close_after_);
        message->prepare_payload();
        Lowest().expires_after(limits().write_timeout);
        http::async_write(
            stream_, *message,
            [self = this->shared_from_this(), message](beast::error_code ec, std::size_t) {
                if (ec == beast::error::timeout) ++self->shared_->stats.timed_out;
                if (ec) return self->Close();
                if (!message->keep_alive()) return self->Linger();
                self->version_ = 0;
                self->WaitForRequest();
            });
    }

    // A streamed response: the head, then the queued chunks one write at a time, then the
    // last chunk; between writes the connection waits without a deadline.
    void WriteStreamHead(HttpResponse response) {
        if (*closed_) return;
        deadline_.cancel();
        auto message = std::make_shared<http::response<http::empty_body>>();
        message->version(version_ == 0 ? 11 : version_);
        message->result(static_cast<unsigned>(response.status));
        for (const auto& [name, value] : response.headers.fields()) message->set(name, value);
        message->set(http::field::content_type, response.content_type);
        message->keep_alive(keep_alive_ && !close_after_);
        message->chunked(true);
        auto serializer = std::make_shared<http::response_serializer<http::empty_body>>(*message);
        writing_ = true;
        Lowest().expires_after(limits().write_timeout);
        http::async_write_header(stream_, *serializer,
                                 [self = this->shared_from_this(), message, serializer](
                                     beast::error_code ec, std::size_t) {
                                     self->OnStreamWrite(ec, message->keep_alive());
                                 });
    }

    void QueueChunk(std::string chunk, bool last) {
        if (*closed_) return;
        if (last) {
            stream_end_ = true;
        } else {
            backlog_ += chunk.size();
            if (backlog_ > kStreamBacklogBytes) return Close();  // a reader that fell behind
            pending_.push_back(std::move(chunk));
        }
        if (!writing_) FlushStream();
    }

    void FlushStream() {
        if (writing_ || *closed_) return;
        if (!pending_.empty()) {
            auto chunk = std::make_shared<std::string>(std::move(pending_.front()));
            pending_.pop_front();
            backlog_ -= chunk->size();
            writing_ = true;
            Lowest().expires_after(limits().write_timeout);
            return net::async_write(
                stream_, http::make_chunk(net::buffer(*chunk)),
                [self = this->shared_from_this(), chunk](beast::error_code ec, std::size_t) {
                    self->OnStreamWrite(ec, self->stream_keep_alive_);
                });
        }
        if (!stream_end_) return;
        stream_end_ = false;
        stream_done_ = true;
        writing_ = true;
        Lowest().expires_after(limits().write_timeout);
        net::async_write(stream_, http::make_chunk_last(),
                         [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
                             self->OnStreamWrite(ec, self->stream_keep_alive_);
                         });
    }

    void OnStreamWrite(beast::error_code ec, bool keep_alive) {
        if (ec == beast::error::timeout) ++shared_->stats.timed_out;
        if (ec) return Close();
        writing_ = false;
        stream_keep_alive_ = keep_alive;
        if (stream_done_) {
            stream_done_ = false;
            if (!keep_alive) return Linger();
            version_ = 0;
            return WaitForRequest();
        }
        Lowest().expires_never();
        FlushStream();
    }

    // Closing with unread bytes would reset the connection and could lose the answer just
    // written: stop sending, read and drop what the client still sends for a moment, then close.
    // TLS first sends its close_notify; what the client sends after it (the rest of a body
    // the answer refused) is dropped undecrypted from the socket, as with plain TCP: closing
    // once async_shutdown gave up on that data reset the client mid-upload.
    void Linger() {
        drain_deadline_ = Clock::now() + kDrainTime;
        if constexpr (std::is_same_v<Stream, TlsStream>) {
            Lowest().expires_at(drain_deadline_);
            stream_.async_shutdown(
                [self = this->shared_from_this()](beast::error_code) { self->DrainSocket(); });
        } else {
            DrainSocket();
        }
    }

    void DrainSocket() {
        beast::error_code ignored;
        Lowest().socket().shutdown(tcp::socket::shutdown_send, ignored);
        Drain();
    }

    void Drain() {
        if (drained_ >= drain_budget_ || Clock::now() >= drain_deadline_) return Close();
        Lowest().expires_at(drain_deadline_);
        Lowest().async_read_some(
            net::buffer(scratch_),
            [self = this->shared_from_this()](beast::error_code ec, std::size_t bytes) {
                if (ec) return self->Close();
                self->drained_ += bytes;
                self->Drain();
            });
    }

    void Close() {
        *closed_ = true;
        beast::error_code ignored;
        Lowest().socket().shutdown(tcp::socket::shutdown_both, ignored);
        Lowest().close();
    }

    std::shared_ptr<Shared> shared_;
    std::shared_ptr<ssl::context> context_;
    Stream stream_;
    beast::flat_buffer buffer_;
    net::steady_timer deadline_;  ///< RespondBy's, armed while a handler works
    std::string peer_;
    std::string tls_identity_;
    std::optional<http::request_parser<http::string_body>> parser_;
    HttpRequest head_;
    std::unique_ptr<BodyReservation> body_;
    Clock::time_point body_started_;
    bool keep_alive_ = true;
    bool close_after_ = false;
    unsigned version_ = 0;
    std::shared_ptr<std::atomic<bool>> closed_ = std::make_shared<std::atomic<bool>>(false);
    Clock::time_point drain_deadline_;
    std::uint64_t drained_ = 0;
    std::uint64_t drain_budget_ = kMinDrainBytes;
    std::array<char, 16384> scratch_{};
    // A streamed response in progress.
    std::deque<std::string> pending_;
    std::size_t backlog_ = 0;
    bool writing_ = false;
    bool stream_end_ = false;
    bool stream_done_ = false;
    bool stream_keep_alive_ = true;
};

std::string PeerOf(const tcp::socket& socket) {
    beast::error_code ec;
    const tcp::endpoint remote = socket.remote_endpoint(ec);
    if (ec) return "unknown";
    const net::ip::address address = remote.address();
    return address.is_v6() ? absl::StrCat("[", address.to_string(), "]:", remote.port())
                           : absl::StrCat(address.to_string(), ":", remote.port());
}

}  // namespace

// ---------------------------------------------------------------------------------------------

absl::Status CheckTlsFiles(const TlsFiles& files) {
    ERR_clear_error();
    return BuildTlsContext(files).status();
}

void HttpHeaders::Add(std::string name, std::string value) {
    fields_.emplace_back(std::move(name), std::move(value));
}

void HttpHeaders::Set(const std::string& name, std::string value) {
    fields_.erase(std::remove_if(
                      fields_.begin(), fields_.end(),
                      [&](const auto& field) { return absl::EqualsIgnoreCase(field.first, name); }),
                  fields_.end());
    fields_.emplace_back(name, std::move(value));
}

const std::string& HttpHeaders::Get(std::string_view name) const {
    for (const auto& [field, value] : fields_) {
        if (absl::EqualsIgnoreCase(field, AbslView(name))) return value;
    }
    return kEmpty;
}

bool HttpHeaders::Has(std::string_view name) const {
    return std::any_of(fields_.begin(), fields_.end(), [&](const auto& field) {
        return absl::EqualsIgnoreCase(field.first, AbslView(name));
    });
}

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
            std::shared_ptr<ssl::context> context = s.tls->Current();
            auto connection = std::make_shared<Connection<TlsStream>>(shared, std::move(peer),
                                                                      std::move(socket), *context);
            connection->KeepContext(std::move(context));
            connection->Start();
        } else {
            std::make_shared<Connection<PlainStream>>(shared, std::move(peer), std::move(socket))
                ->Start();
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
        impl_->threads.emplace_back([this] { impl_->io.run(); });
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
