#include "server/grpc/health_service.hpp"

#include <chrono>
#include <optional>

namespace soilvol::server {

using grpc::health::v1::HealthCheckRequest;
using grpc::health::v1::HealthCheckResponse;

/// One Watch stream: writes the current status, then each change; one write at a time.
class HealthService::Watcher final : public grpc::ServerWriteReactor<HealthCheckResponse> {
  public:
    Watcher(HealthService* service, std::string name) : service_(service), name_(std::move(name)) {}

    void Push(ServingStatus status, bool last) {
        std::lock_guard<std::mutex> lock(mutex_);
        if (finished_) return;
        if (writing_) {
            pending_ = status;
            pending_last_ = pending_last_ || last;
            return;
        }
        if (sent_ && *sent_ == status) {
            if (last) FinishLocked();
            return;
        }
        WriteLocked(status, last);
    }

    void OnWriteDone(bool ok) override {
        std::lock_guard<std::mutex> lock(mutex_);
        writing_ = false;
        if (!ok) return FinishLocked();
        if (closing_) return FinishLocked();
        if (pending_) {
            const ServingStatus status = *pending_;
            pending_.reset();
            if (status != *sent_ || pending_last_) {
                WriteLocked(status, pending_last_);
            }
        }
    }

    void OnCancel() override {
        std::lock_guard<std::mutex> lock(mutex_);
        FinishLocked();
    }

    void OnDone() override {
        service_->Remove(this);
        delete this;
    }

    const std::string& name() const { return name_; }

  private:
    void WriteLocked(ServingStatus status, bool last) {
        sent_ = status;
        response_.set_status(status);
        writing_ = true;
        closing_ = last;
        StartWrite(&response_);
    }

    void FinishLocked() {
        if (finished_) return;
        finished_ = true;
        Finish(grpc::Status::OK);
    }

    HealthService* service_;
    const std::string name_;
    std::mutex mutex_;
    HealthCheckResponse response_;
    std::optional<ServingStatus> sent_;
    std::optional<ServingStatus> pending_;
    bool pending_last_ = false;
    bool writing_ = false;
    bool closing_ = false;
    bool finished_ = false;
};

HealthService::HealthService(std::function<bool()> ready) : ready_(std::move(ready)) {
    ready_now_ = ready_();
    monitor_ = std::thread([this] { Monitor(); });
}

HealthService::~HealthService() {
    BeginShutdown();
    monitor_.join();
}

HealthService::ServingStatus HealthService::StatusOf(const std::string& service) const {
    if (service == "liveness") {
        return shutting_down_ ? HealthCheckResponse::NOT_SERVING : HealthCheckResponse::SERVING;
    }
    if (service.empty() || service == "soilvol.v1.SoilVolume") {
        return !shutting_down_ && ready_now_ ? HealthCheckResponse::SERVING
                                             : HealthCheckResponse::NOT_SERVING;
    }
    return HealthCheckResponse::SERVICE_UNKNOWN;
}

grpc::ServerUnaryReactor* HealthService::Check(grpc::CallbackServerContext* context,
                                               const HealthCheckRequest* request,
                                               HealthCheckResponse* response) {
    grpc::ServerUnaryReactor* reactor = context->DefaultReactor();
    const ServingStatus status = StatusOf(request->service());
    if (status == HealthCheckResponse::SERVICE_UNKNOWN) {
        reactor->Finish(grpc::Status(grpc::StatusCode::NOT_FOUND,
                                     "unknown service '" + request->service() + "'"));
    } else {
        response->set_status(status);
        reactor->Finish(grpc::Status::OK);
    }
    return reactor;
}

grpc::ServerWriteReactor<HealthCheckResponse>* HealthService::Watch(
    grpc::CallbackServerContext*, const HealthCheckRequest* request) {
    auto* watcher = new Watcher(this, request->service());
    {
        std::lock_guard<std::mutex> lock(mutex_);
        watchers_.insert(watcher);
    }
    watcher->Push(StatusOf(request->service()), shutting_down_);
    return watcher;
}

void HealthService::BeginShutdown() {
    {
        std::lock_guard<std::mutex> lock(mutex_);
        shutting_down_ = true;
        for (Watcher* watcher : watchers_) watcher->Push(StatusOf(watcher->name()), true);
    }
    wake_.notify_all();
}

void HealthService::Monitor() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!shutting_down_) {
        wake_.wait_for(lock, std::chrono::seconds(1), [this] { return shutting_down_.load(); });
        if (shutting_down_) break;
        lock.unlock();
        ready_now_ = ready_();
        lock.lock();
        for (Watcher* watcher : watchers_) watcher->Push(StatusOf(watcher->name()), false);
    }
}

void HealthService::Remove(Watcher* watcher) {
    std::lock_guard<std::mutex> lock(mutex_);
    watchers_.erase(watcher);
}

}  // namespace soilvol::server
