#pragma once

#include <atomic>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <set>
#include <string>
#include <thread>

#include "grpc/health/v1/health.grpc.pb.h"

namespace soilvol::server {

/// grpc.health.v1.Health, compiled from Debian's grpc-proto so that reflection describes it.
/// Services: "" and "soilvol.v1.SoilVolume" are SERVING while the server is ready (the data
/// directory takes writes and no shutdown began); "liveness" is SERVING until shutdown. Other
/// names are NOT_FOUND (Check) or SERVICE_UNKNOWN (Watch). Watch streams every change, polled
/// once a second.
class HealthService final : public grpc::health::v1::Health::CallbackService {
  public:
    using ServingStatus = grpc::health::v1::HealthCheckResponse::ServingStatus;
    class Watcher;

    explicit HealthService(std::function<bool()> ready);
    ~HealthService() override;

    grpc::ServerUnaryReactor* Check(grpc::CallbackServerContext* context,
                                    const grpc::health::v1::HealthCheckRequest* request,
                                    grpc::health::v1::HealthCheckResponse* response) override;
    grpc::ServerWriteReactor<grpc::health::v1::HealthCheckResponse>* Watch(
        grpc::CallbackServerContext* context,
        const grpc::health::v1::HealthCheckRequest* request) override;

    /// Everything NOT_SERVING from now on; open Watch streams get that and are finished.
    void BeginShutdown();
    /// Status of `service` now.
    ServingStatus StatusOf(const std::string& service) const;

  private:
    friend class Watcher;
    void Monitor();
    void Remove(Watcher* watcher);

    std::function<bool()> ready_;
    std::atomic<bool> shutting_down_{false};
    std::atomic<bool> ready_now_{false};
    mutable std::mutex mutex_;
    std::condition_variable wake_;
    std::set<Watcher*> watchers_;
    std::thread monitor_;
};

}  // namespace soilvol::server
