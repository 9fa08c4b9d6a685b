#pragma once

// What the connections of one HttpServer share (internal to server/http).

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/status.h"
#include "server/http/http_server.hpp"
#include "server/http/tls_context.hpp"

namespace soilvol::server::http_detail {

// Read and dropped before closing on a refusal, so that a client still sending its body reads
// the answer instead of a reset: what it announced (at least 1 MiB), within 5 s.
inline constexpr std::uint64_t kMinDrainBytes = 1 << 20;
inline constexpr std::chrono::seconds kDrainTime{5};

struct Shared {
    HttpServerOptions options;
    HttpServer::Admit admit;
    HttpServer::Handle handle;
    HttpConnectionStats stats;
    std::unique_ptr<TlsContextSource> tls;

    /// Takes `bytes` from max_inflight_body_bytes; false when they do not fit.
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

/// An error answer: the google.rpc.Status as JSON, Retry-After when the error says when.
HttpResponse ErrorResponse(int status, const absl::Status& error);
/// An error answer from a code and message; a 413 carries no retry hint.
HttpResponse ErrorResponse(int status, absl::StatusCode code, const std::string& message);
/// 429: the server holds all the body bytes it may.
HttpResponse UploadBudgetFull();

}  // namespace soilvol::server::http_detail
