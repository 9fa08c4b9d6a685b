#pragma once

// One connection of HttpServer (internal to server/http; included by connection_plain.cpp and
// connection_tls.cpp only, which compile the two streams apart): read a request within the
// limits, admit it, read its body, hand it over, write the answer or stream it, and again
// while the client keeps the connection.

#include <poll.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>
#include <chrono>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "server/http/connection_state.hpp"

namespace soilvol::server::http_detail {

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
namespace ssl = net::ssl;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;
using PlainStream = beast::tcp_stream;
using TlsStream = beast::ssl_stream<beast::tcp_stream>;

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

    bool SendPaced(std::string chunk, Clock::time_point deadline) override {
        std::shared_ptr<Connection<Stream>> connection = Current();
        if (!connection) return false;
        // Polling on the producer's own (worker) thread: the writes drain the count on the
        // connection's; a millisecond is far below a chunk's time on any network.
        while (connection->unsent_bytes() > kPacedBacklogBytes) {
            if (Gone() || Clock::now() > deadline) return false;
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        return Send(std::move(chunk));
    }

    void Abort() override {
        if (!streaming_ || finished_.exchange(true)) return;
        std::shared_ptr<Connection<Stream>> connection;
        {
            std::lock_guard<std::mutex> lock(mutex_);
            connection = std::move(connection_);
        }
        if (connection) connection->PostClose();
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
          watchdog_(stream_.get_executor()),
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

    /// One chunk of a streamed response, or its end (`last`). Chunks posted before the
    /// connection's thread took the earlier ones join them and leave in one write: a feed that
    /// hands a thousand streams several events each, faster than the threads write them, costs
    /// a write per stream, not one per event.
    void PostStreamChunk(std::string chunk, bool last) {
        unsent_bytes_ += chunk.size();
        {
            std::lock_guard<std::mutex> lock(outbox_mutex_);
            if (outbox_.empty()) {
                outbox_ = std::move(chunk);
            } else {
                outbox_ += chunk;
            }
            outbox_last_ = outbox_last_ || last;
            if (outbox_posted_) return;
            outbox_posted_ = true;
        }
        net::post(stream_.get_executor(),
                  [self = this->shared_from_this()] { self->TakeOutbox(); });
    }

    /// Ends the connection without the stream's last chunk: the client sees the response cut
    /// short (a failed download), not a complete one.
    void PostClose() {
        net::post(stream_.get_executor(), [self = this->shared_from_this()] { self->Close(); });
    }

    /// Bytes of streamed chunks posted and not yet written to the socket.
    std::size_t unsent_bytes() const { return unsent_bytes_.load(); }

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
            tls_identity_ = PeerCertificateSubject(stream_.native_handle());
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
        WatchForHangUp();
    }

    // A streaming client (an EventSource, curl -N) sends nothing while it listens, so the
    // socket turning readable - its FIN, a TLS close_notify, a reset - means it left: the
    // connection closes at once, and its watch ends at its next heartbeat, instead of after
    // the writes into a gone client's socket buffer first fail. (A request pipelined behind a
    // streamed response closes it too; no browser pipelines.)
    void WatchForHangUp() {
        const std::uint64_t stream = ++stream_serial_;
        Lowest().socket().async_wait(tcp::socket::wait_read, [self = this->shared_from_this(),
                                                              stream](beast::error_code ec) {
            if (ec || stream != self->stream_serial_) return;  // the stream ended first
            // Its last chunk is on its way: what arrived is the client's next request.
            if (self->stream_end_ || self->stream_done_) return;
            self->Close();
        });
    }

    void TakeOutbox() {
        std::string chunk;
        bool last = false;
        {
            std::lock_guard<std::mutex> lock(outbox_mutex_);
            chunk.swap(outbox_);
            std::swap(last, outbox_last_);
            outbox_posted_ = false;
        }
        if (*closed_) return;
        if (pending_.empty()) {
            pending_ = std::move(chunk);
        } else {
            pending_ += chunk;
        }
        if (pending_.size() > kStreamBacklogBytes) return Close();  // a reader that fell behind
        stream_end_ = stream_end_ || last;
        FlushStream();
    }

    // What is pending goes as one chunk: a reader that was behind gets all it missed at once.
    void FlushStream() {
        if (writing_ || *closed_) return;
        if (!pending_.empty()) {
            auto chunk = std::make_shared<std::string>(std::move(pending_));
            pending_.clear();
            beast::buffers_suffix<decltype(http::make_chunk(net::buffer(*chunk)))> rest(
                http::make_chunk(net::buffer(*chunk)));
            rest.consume(WriteNow(rest));
            if (beast::buffer_bytes(rest) == 0) {
                unsent_bytes_ -= chunk->size();
            } else {
                StartChunkWrite();
                return net::async_write(
                    stream_, rest,
                    [self = this->shared_from_this(), chunk](beast::error_code ec, std::size_t) {
                        self->unsent_bytes_ -= chunk->size();
                        self->OnStreamWrite(ec, self->stream_keep_alive_);
                    });
            }
        }
        if (!stream_end_) return;
        stream_end_ = false;
        stream_done_ = true;
        StartChunkWrite();
        net::async_write(stream_, http::make_chunk_last(),
                         [self = this->shared_from_this()](beast::error_code ec, std::size_t) {
                             self->OnStreamWrite(ec, self->stream_keep_alive_);
                         });
    }

    // With no write under way, a plain connection's chunk goes to the socket at once, in this
    // handler, as far as the socket takes it without blocking; an asynchronous write (and its
    // completion handler) is needed only for what is left - a reader that fell behind. Over TLS
    // every write goes through the stream. Returns the bytes written.
    template <typename Buffers>
    std::size_t WriteNow(const Buffers& buffers) {
        if constexpr (std::is_same_v<Stream, PlainStream>) {
            tcp::socket& socket = Lowest().socket();
            beast::error_code ec;
            if (!socket.non_blocking()) socket.non_blocking(true, ec);
            const std::size_t written = ec ? 0 : socket.write_some(buffers, ec);
            return ec ? 0 : written;  // an error shows again in the asynchronous write
        } else {
            return 0;
        }
    }

    // A chunk's write has no timer of its own (arming and cancelling one per write was a
    // third of a delivery's handlers at a thousand watchers): one watchdog per connection,
    // armed at most once per write timeout, closes a stream whose current write has taken
    // longer than the timeout - a client that stopped reading with its window full.
    void StartChunkWrite() {
        writing_ = true;
        chunk_writing_ = true;
        chunk_started_ = Clock::now();
        if (!watchdog_armed_) ArmWatchdog(chunk_started_ + limits().write_timeout);
    }

    void ArmWatchdog(Clock::time_point when) {
        watchdog_armed_ = true;
        watchdog_.expires_at(when);
        watchdog_.async_wait([self = this->shared_from_this()](beast::error_code ec) {
            self->watchdog_armed_ = false;
            if (ec || *self->closed_ || !self->chunk_writing_) return;
            const Clock::time_point due = self->chunk_started_ + self->limits().write_timeout;
            if (Clock::now() < due) return self->ArmWatchdog(due);
            ++self->shared_->stats.timed_out;
            self->Close();
        });
    }

    void OnStreamWrite(beast::error_code ec, bool keep_alive) {
        chunk_writing_ = false;
        if (ec == beast::error::timeout) ++shared_->stats.timed_out;
        if (ec) return Close();
        writing_ = false;
        stream_keep_alive_ = keep_alive;
        if (stream_done_) {
            stream_done_ = false;
            ++stream_serial_;  // the hang-up watch is void; the next request may come
            beast::error_code ignored;
            Lowest().socket().cancel(ignored);
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
        watchdog_.cancel();
        beast::error_code ignored;
        Lowest().socket().shutdown(tcp::socket::shutdown_both, ignored);
        Lowest().close();
    }

    std::shared_ptr<Shared> shared_;
    std::shared_ptr<ssl::context> context_;
    Stream stream_;
    beast::flat_buffer buffer_;
    net::steady_timer deadline_;  ///< RespondBy's, armed while a handler works
    net::steady_timer watchdog_;  ///< a streamed chunk's write timeout (StartChunkWrite)
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
    std::mutex outbox_mutex_;  ///< guards the three below, which any thread posts to
    std::string outbox_;       ///< chunks posted and not yet taken by the connection's thread
    bool outbox_last_ = false;
    bool outbox_posted_ = false;                ///< a TakeOutbox is on its way
    std::string pending_;                       ///< taken, not yet written (a write is under way)
    std::atomic<std::size_t> unsent_bytes_{0};  ///< posted chunks not yet written (SendPaced)
    bool writing_ = false;
    bool chunk_writing_ = false;  ///< a streamed chunk's write is under way
    bool watchdog_armed_ = false;
    Clock::time_point chunk_started_;
    bool stream_end_ = false;
    bool stream_done_ = false;
    bool stream_keep_alive_ = true;
    std::uint64_t stream_serial_ = 0;  ///< bumped per stream and at its end (WatchForHangUp)
};

}  // namespace soilvol::server::http_detail
