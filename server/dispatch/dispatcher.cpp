#include "server/dispatch/dispatcher.hpp"

#include <cmath>
#include <memory>

#include "absl/strings/str_cat.h"
#include "server/base/logging.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

double MsSince(Clock::time_point start) {
    return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

std::string IdsText(const CallRecord& record) {
    std::string text;
    for (const auto& [key, value] : record.ids) {
        absl::StrAppend(&text, text.empty() ? "" : " ", key, "=", value);
    }
    return text;
}

// An internal error's message (an OpenCV source path, a library's exception text) stays in
// the log line above; the caller learns that it happened and when to look.
absl::Status ClientFacing(const absl::Status& status) {
    if (status.code() != absl::StatusCode::kInternal &&
        status.code() != absl::StatusCode::kUnknown) {
        return status;
    }
    return absl::Status(status.code(),
                        "internal error: the server logged its details with this request");
}

absl::Status LateAnswer(const CallContext& context) {
    if (Clock::now() <= context.deadline) return absl::OkStatus();
    return absl::DeadlineExceededError(
        absl::StrCat("deadline expired while computing (",
                     static_cast<long long>(MsSince(context.received)), " ms)"));
}

}  // namespace

Dispatcher::Dispatcher(WorkerPool& pool, Metrics& metrics, const Authenticator& authenticator)
    : pool_(pool), metrics_(metrics), authenticator_(authenticator) {}

absl::Status Dispatcher::Authorize(CallContext& context) const {
    absl::StatusOr<Scope> scope = RequiredScope(context.method);
    if (!scope.ok()) return absl::InternalError(scope.status().message());
    Principal who;
    const absl::Status status =
        authenticator_.Authorize(*scope, context.authorization, context.tls_identity, &who);
    context.principal = who.name;
    return status;
}

void Dispatcher::Submit(CallContext context, Work work, Done done) {
    if (absl::Status allowed = Authorize(context); !allowed.ok()) {
        Finish(context, CallRecord{}, allowed, done);
        return;
    }
    // The task owns everything it needs; whichever of run/reject fires consumes it.
    auto state = std::make_shared<std::tuple<CallContext, Work, Done>>(
        std::move(context), std::move(work), std::move(done));
    WorkerPool::Task task;
    task.run = [this, state] {
        auto& [ctx, run_work, run_done] = *state;
        CallRecord record;
        record.queue_ms = MsSince(ctx.received);
        record.stop = StopToken(ctx.deadline, [cancelled = ctx.cancelled, stop_all = stop_all_] {
            return stop_all->load() || (cancelled && cancelled());
        });
        absl::Status status;
        if (Clock::now() >= ctx.deadline) {
            status = absl::DeadlineExceededError(
                absl::StrCat("deadline expired after ", static_cast<long long>(record.queue_ms),
                             " ms waiting for a worker"));
        } else if (record.stop.StopRequested()) {
            status = record.stop.Check("the wait for a worker");
        } else {
            status = run_work(record);
            if (status.ok() && record.finish_later) {
                auto later = std::move(record.finish_later);
                auto kept = std::make_shared<CallRecord>(std::move(record));
                later([this, state, kept](absl::Status result) {
                    auto& [late_ctx, late_work, late_done] = *state;
                    if (result.ok()) result = LateAnswer(late_ctx);
                    Finish(late_ctx, *kept, result, late_done);
                });
                return;
            }
            if (status.ok()) status = LateAnswer(ctx);
        }
        Finish(ctx, record, status, run_done);
    };
    task.reject = [this, state] {
        auto& [ctx, run_work, run_done] = *state;
        Finish(ctx, CallRecord{},
               WithReason(absl::UnavailableError("the server is shutting down"), "SHUTTING_DOWN"),
               run_done);
    };
    if (!pool_.TrySubmit(task)) {
        auto& [ctx, run_work, run_done] = *state;
        Finish(ctx, CallRecord{},
               WithReason(absl::ResourceExhaustedError(absl::StrCat(
                              "server busy: all ", pool_.workers(), " workers are busy and ",
                              pool_.max_queue(), " requests are waiting; retry later")),
                          "QUEUE_FULL"),
               run_done);
    }
}

void Dispatcher::Refuse(const CallContext& context, const absl::Status& status) {
    Finish(context, CallRecord{}, status, [](const absl::Status&) {});
}

void Dispatcher::Finish(const CallContext& context, const CallRecord& record,
                        const absl::Status& status, const Done& done) {
    const double total_ms = MsSince(context.received);
    metrics_.RecordRequest(context.method, context.transport, status.code(), total_ms / 1000.0);
    if (record.queue_ms > 0.0) metrics_.RecordStage("queue", record.queue_ms / 1000.0);
    for (const auto& [stage, ms] : record.stages_ms) metrics_.RecordStage(stage, ms / 1000.0);
    if (status.ok() && record.measured) {
        const CallRecord::Measured& m = *record.measured;
        metrics_.RecordEstimate(m.container_id, m.load_status, record.volume_m3.value_or(0.0),
                                m.bank_volume_m3, m.mass_kg);
    }
    const LogLevel level = status.ok()                           ? LogLevel::kInfo
                           : HttpStatusFor(status.code()) >= 500 ? LogLevel::kError
                                                                 : LogLevel::kWarn;
    LogEvent(level, "request",
             {{"method", context.method},
              {"request_id", context.request_id},
              {"trace_id", context.trace_id},
              {"transport", context.transport},
              {"peer", context.peer},
              {"principal", context.principal},
              {"ids", IdsText(record)},
              {"status", CodeName(status.code())},
              {"ms", total_ms},
              {"queue_ms", record.queue_ms},
              {"volume_m3", record.volume_m3.value_or(std::nan(""))},
              {"error", status.message()}});
    // Who changed what, and how it ended: one line per call that needs the admin scope.
    const absl::StatusOr<Scope> scope = RequiredScope(context.method);
    if (scope.ok() && *scope == Scope::kAdmin) {
        LogEvent(LogLevel::kInfo, "audit",
                 {{"principal", context.principal.empty() ? "unauthenticated" : context.principal},
                  {"method", context.method},
                  {"request_id", context.request_id},
                  {"transport", context.transport},
                  {"peer", context.peer},
                  {"ids", IdsText(record)},
                  {"status", CodeName(status.code())}});
    }
    done(ClientFacing(status));
}

}  // namespace soilvol::server
