#include "server/grpc/grpc_service.hpp"

#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>

#include "server/base/call_ids.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

/// StreamEstimates: reads one scan, estimates it on the pool, writes the answer, reads the
/// next. One scan in flight per stream keeps the order and lets slow clients push back.
class EstimateStream final
    : public grpc::ServerBidiReactor<v1::EstimateVolumeRequest, v1::StreamEstimatesResponse> {
  public:
    EstimateStream(grpc::CallbackServerContext* context, SoilVolumeHandlers& handlers,
                   Dispatcher& dispatcher)
        : context_(context),
          handlers_(handlers),
          dispatcher_(dispatcher),
          request_id_(GrpcCallContext(context, "StreamEstimates").request_id) {
        context_->AddInitialMetadata("x-request-id", request_id_);
        StartRead(&request_);
    }

    void OnReadDone(bool ok) override {
        if (!ok) {  // the client half-closed (or went away): every answer is written
            Finish(grpc::Status::OK);
            return;
        }
        response_.Clear();
        response_.set_sequence(sequence_++);
        response_.set_request_id(request_.request_id());
        CallContext call = GrpcCallContext(context_, "StreamEstimates");
        call.request_id = request_id_;  // one per stream, as echoed
        dispatcher_.Submit(
            std::move(call),
            [this](CallRecord& record) {
                return handlers_.EstimateVolume(request_, response_.mutable_estimate(), record);
            },
            [this](const absl::Status& status) {
                if (!status.ok()) *response_.mutable_error() = RpcStatusOf(status);
                StartWrite(&response_);
            });
    }

    void OnWriteDone(bool ok) override {
        if (!ok) {
            Finish(grpc::Status(grpc::StatusCode::CANCELLED, "the stream broke while writing"));
            return;
        }
        StartRead(&request_);
    }

    void OnDone() override { delete this; }

  private:
    grpc::CallbackServerContext* context_;
    SoilVolumeHandlers& handlers_;
    Dispatcher& dispatcher_;
    v1::EstimateVolumeRequest request_;
    v1::StreamEstimatesResponse response_;
    const std::string request_id_;
    int64_t sequence_ = 0;
};

/// WatchEstimates, WatchAlerts and WatchLoads: what the feed delivers is queued (at most
/// kMaxQueued; beyond, the watch ends as too slow) and written one at a time. The shared State
/// outlives the reactor, so a message the feed hands over while the call ends finds no reactor
/// rather than a dangling one.
template <typename Message>
class WatchStream final : public grpc::ServerWriteReactor<Message> {
  public:
    static constexpr std::size_t kMaxQueued = 256;
    /// Starts the handler's watch with these callbacks; returns what stops it.
    using Start = std::function<absl::StatusOr<std::function<void()>>(
        std::function<bool(const Message*)>, std::function<void(const absl::Status&)>)>;

    WatchStream(grpc::CallbackServerContext* context, Dispatcher& dispatcher, const char* method,
                const Start& start)
        : state_(std::make_shared<State>()) {
        state_->reactor = this;
        CallContext call = GrpcCallContext(context, method);
        context->AddInitialMetadata("x-request-id", call.request_id);
        if (absl::Status allowed = dispatcher.Authorize(call); !allowed.ok()) {
            dispatcher.Refuse(call, allowed);
            FinishOnce(ToGrpcStatus(allowed));
            return;
        }
        std::shared_ptr<State> state = state_;
        absl::StatusOr<std::function<void()>> stop =
            start([state](const Message* message) { return state->Push(message); },
                  [state](const absl::Status& status) { state->End(ToGrpcStatus(status)); });
        if (!stop.ok()) {
            dispatcher.Refuse(call, stop.status());
            FinishOnce(ToGrpcStatus(stop.status()));
            return;
        }
        stop_ = *std::move(stop);
        this->StartSendInitialMetadata();  // the client sees the watch is on before any message
    }

    void OnWriteDone(bool ok) override {
        std::lock_guard<std::recursive_mutex> lock(state_->mutex);
        state_->queue.pop_front();
        if (!ok) {
            state_->writing = false;
            state_->FinishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "the client left"));
            return;
        }
        if (!state_->queue.empty()) {
            this->StartWrite(&state_->queue.front());
            return;
        }
        state_->writing = false;
        if (state_->pending_finish) state_->FinishLocked(*state_->pending_finish);
    }

    void OnCancel() override { StopWatch(); }

    void OnDone() override {
        StopWatch();
        {
            std::lock_guard<std::recursive_mutex> lock(state_->mutex);
            state_->reactor = nullptr;
        }
        delete this;
    }

  private:
    struct State {
        std::recursive_mutex mutex;  // gRPC may run a reaction inline
        WatchStream* reactor = nullptr;
        std::deque<Message> queue;  // front: being written
        bool writing = false;
        bool finished = false;
        std::optional<grpc::Status> pending_finish;

        bool Push(const Message* message) {
            std::lock_guard<std::recursive_mutex> lock(mutex);
            if (reactor == nullptr || finished) return false;
            if (message == nullptr) return true;  // heartbeat: gRPC keepalive covers it
            if (queue.size() >= kMaxQueued) return false;
            queue.push_back(*message);
            if (!writing) {
                writing = true;
                reactor->StartWrite(&queue.front());
            }
            return true;
        }
        void End(const grpc::Status& status) {
            std::lock_guard<std::recursive_mutex> lock(mutex);
            if (writing) {
                pending_finish = status;  // after what is queued
            } else {
                FinishLocked(status);
            }
        }
        void FinishLocked(const grpc::Status& status) {
            if (reactor == nullptr || finished) return;
            finished = true;
            reactor->Finish(status);
        }
    };

    void FinishOnce(const grpc::Status& status) {
        std::lock_guard<std::recursive_mutex> lock(state_->mutex);
        state_->FinishLocked(status);
    }
    void StopWatch() {
        std::function<void()> stop;
        {
            std::lock_guard<std::recursive_mutex> lock(state_->mutex);
            stop.swap(stop_);
        }
        if (stop) stop();  // no callback runs after it returns
        FinishOnce(grpc::Status(grpc::StatusCode::CANCELLED, "the client left"));
    }

    std::shared_ptr<State> state_;
    std::function<void()> stop_;
};

}  // namespace

grpc::Status ToGrpcStatus(const absl::Status& status) {
    if (status.ok()) return grpc::Status::OK;
    // The details travel as the google.rpc.Status in the grpc-status-details-bin trailer.
    return grpc::Status(static_cast<grpc::StatusCode>(status.code()), SafeMessage(status.message()),
                        RpcStatusBytes(status));
}

CallContext GrpcCallContext(grpc::CallbackServerContext* context, const char* method) {
    CallContext call;
    call.method = method;
    call.transport = "grpc";
    call.peer = context->peer();
    // A deadline more than a day away is no deadline (gRPC reports "none" as the far future).
    const auto left = context->deadline() - std::chrono::system_clock::now();
    if (left < std::chrono::hours(24)) {
        call.deadline = call.received + std::chrono::duration_cast<Clock::duration>(left);
    }
    // gRPC also cancels a call at its deadline: that one is the deadline's (DEADLINE_EXCEEDED,
    // from call.deadline), not a cancel by the client.
    call.cancelled = [context] {
        return context->IsCancelled() && std::chrono::system_clock::now() < context->deadline();
    };
    const auto& metadata = context->client_metadata();
    if (auto found = metadata.find("authorization"); found != metadata.end()) {
        call.authorization.assign(found->second.data(), found->second.size());
    }
    const auto found_id = metadata.find("x-request-id");
    call.request_id =
        RequestIdOf(found_id == metadata.end()
                        ? std::string_view()
                        : std::string_view(found_id->second.data(), found_id->second.size()));
    if (auto found = metadata.find("traceparent"); found != metadata.end()) {
        call.trace_id = TraceIdOf(std::string_view(found->second.data(), found->second.size()));
    }
    // The TLS layer verified the certificate (mTLS); its subject names the caller.
    const std::shared_ptr<const grpc::AuthContext> auth = context->auth_context();
    if (auth != nullptr && auth->IsPeerAuthenticated()) {
        for (const grpc::string_ref& subject : auth->FindPropertyValues("x509_subject")) {
            call.tls_identity.assign(subject.data(), subject.size());
        }
    }
    return call;
}

SoilVolumeService::SoilVolumeService(const std::map<std::string, Rpc>& rpcs,
                                     SoilVolumeHandlers& handlers, Dispatcher& dispatcher)
    : rpcs_(rpcs), handlers_(handlers), dispatcher_(dispatcher) {}

grpc::ServerUnaryReactor* SoilVolumeService::Unary(grpc::CallbackServerContext* context,
                                                   const char* method,
                                                   const google::protobuf::Message* request,
                                                   google::protobuf::Message* response) {
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    CallContext call = GrpcCallContext(context, method);
    context->AddInitialMetadata("x-request-id", call.request_id);
    const Rpc* rpc = &rpcs_.at(method);  // CheckRpcTable made sure at start
    dispatcher_.Submit(
        std::move(call),
        [rpc, request, response](CallRecord& record) {
            return rpc->call(*request, response, record);
        },
        [reactor](const absl::Status& status) { reactor->Finish(ToGrpcStatus(status)); });
    return reactor;
}

#define SOILVOL_UNARY_RPC(Name, Request, Response)                                          \
    grpc::ServerUnaryReactor* SoilVolumeService::Name(grpc::CallbackServerContext* context, \
                                                      const v1::Request* request,           \
                                                      v1::Response* response) {             \
        return Unary(context, #Name, request, response);                                    \
    }

SOILVOL_UNARY_RPCS(SOILVOL_UNARY_RPC)
#undef SOILVOL_UNARY_RPC

grpc::ServerWriteReactor<v1::Estimate>* SoilVolumeService::WatchEstimates(
    grpc::CallbackServerContext* context, const v1::WatchEstimatesRequest* request) {
    return new WatchStream<v1::Estimate>(
        context, dispatcher_, "WatchEstimates", [this, request](auto deliver, auto ended) {
            return handlers_.WatchEstimates(*request, std::move(deliver), std::move(ended));
        });
}

grpc::ServerWriteReactor<v1::Alert>* SoilVolumeService::WatchAlerts(
    grpc::CallbackServerContext* context, const v1::WatchAlertsRequest* request) {
    return new WatchStream<v1::Alert>(
        context, dispatcher_, "WatchAlerts", [this, request](auto deliver, auto ended) {
            return handlers_.WatchAlerts(*request, std::move(deliver), std::move(ended));
        });
}

grpc::ServerWriteReactor<v1::LoadEvent>* SoilVolumeService::WatchLoads(
    grpc::CallbackServerContext* context, const v1::WatchLoadsRequest* request) {
    return new WatchStream<v1::LoadEvent>(
        context, dispatcher_, "WatchLoads", [this, request](auto deliver, auto ended) {
            return handlers_.WatchLoads(*request, std::move(deliver), std::move(ended));
        });
}

grpc::ServerBidiReactor<v1::EstimateVolumeRequest, v1::StreamEstimatesResponse>*
SoilVolumeService::StreamEstimates(grpc::CallbackServerContext* context) {
    return new EstimateStream(context, handlers_, dispatcher_);
}

}  // namespace soilvol::server
