#include "server/server.hpp"

#include <condition_variable>
#include <mutex>

#include "absl/strings/str_cat.h"
#include "core/pipeline/parallelism.hpp"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/grpcpp.h"
#include "server/cpu_budget.hpp"
#include "server/dispatcher.hpp"
#include "server/grpc_service.hpp"
#include "server/health_service.hpp"
#include "server/http_gateway.hpp"
#include "server/logging.hpp"
#include "server/metrics.hpp"
#include "server/rpc_table.hpp"
#include "server/soilvol_handlers.hpp"
#include "server/store/entry_store.hpp"
#include "server/worker_pool.hpp"

namespace soilvol::server {

struct Server::Parts {
    ServerOptions options;
    std::unique_ptr<EntryStore> store;
    Metrics metrics;
    std::unique_ptr<WorkerPool> pool;
    std::unique_ptr<Dispatcher> dispatcher;
    std::unique_ptr<SoilVolumeHandlers> handlers;
    std::unique_ptr<SoilVolumeService> service;
    std::unique_ptr<HealthService> health;
    std::unique_ptr<HttpGateway> gateway;
    std::unique_ptr<grpc::Server> grpc_server;
    int grpc_port = 0;
    int http_port = 0;

    std::mutex mutex;
    std::condition_variable stopped_cv;
    bool stopping = false;
    bool stopped = false;
};

Server::Server(std::unique_ptr<Parts> parts) : parts_(std::move(parts)) {}

Server::~Server() { Shutdown(); }

absl::StatusOr<std::unique_ptr<Server>> Server::BuildAndStart(const ServerOptions& raw) {
    if (absl::Status status = ValidateOptions(raw); !status.ok()) return status;
    auto parts = std::make_unique<Parts>();
    Parts& p = *parts;
    p.options = ResolveOptions(raw);
    const ServerOptions& o = p.options;

    absl::StatusOr<std::unique_ptr<EntryStore>> store = EntryStore::Open(o.data_dir);
    if (!store.ok()) return store.status();
    p.store = *std::move(store);
    Metrics* metrics = &p.metrics;
    // Busy, the workers run at most two engine threads per CPU (ThreadsPerCall), for the
    // OpenMP loops (set per worker thread) and OpenCV's loops (process-wide).
    const int call_threads = ThreadsPerCall(o.cpus, o.workers);
    pipeline::SetOpenCvThreads(call_threads);
    p.pool = std::make_unique<WorkerPool>(
        o.workers, o.max_queue,
        [metrics](std::size_t running, std::size_t queued) {
            metrics->SetLoad(static_cast<double>(running), static_cast<double>(queued));
        },
        [call_threads] { pipeline::SetCallThreads(call_threads); });
    p.metrics.SetWorkers(o.workers, o.max_queue);
    p.dispatcher = std::make_unique<Dispatcher>(*p.pool, p.metrics);
    p.handlers = std::make_unique<SoilVolumeHandlers>(*p.store);
    p.service = std::make_unique<SoilVolumeService>(*p.handlers, *p.dispatcher);
    SoilVolumeHandlers* handlers = p.handlers.get();
    p.health = std::make_unique<HealthService>([handlers] { return handlers->CheckReady().ok(); });

    const google::protobuf::ServiceDescriptor* api =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
            "soilvol.v1.SoilVolume");
    if (api == nullptr) return absl::InternalError("soilvol.v1.SoilVolume is not linked in");
    absl::StatusOr<std::vector<HttpRoute>> routes = RoutesFromAnnotations(*api);
    if (!routes.ok()) return routes.status();
    HttpGatewayOptions http;
    http.address = o.http_address;
    const std::size_t message_bytes = static_cast<std::size_t>(o.max_message_mb) << 20;
    http.max_body_bytes = message_bytes / 3 * 4 + (1u << 20);  // base64 plus the JSON around it
    http.cors_origins = o.cors_origins;
    http.threads = o.http_threads;
    HealthService* health = p.health.get();
    p.gateway = std::make_unique<HttpGateway>(
        http, MakeRpcTable(*p.handlers), *std::move(routes), *p.dispatcher, p.metrics, [health] {
            return health->StatusOf("") == grpc::health::v1::HealthCheckResponse::SERVING;
        });

    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
    grpc::ServerBuilder builder;
    builder.AddListeningPort(o.grpc_address, grpc::InsecureServerCredentials(), &p.grpc_port);
    builder.SetMaxReceiveMessageSize(static_cast<int>(message_bytes));
    builder.SetMaxSendMessageSize(static_cast<int>(message_bytes));
    builder.RegisterService(p.service.get());
    builder.RegisterService(p.health.get());
    p.grpc_server = builder.BuildAndStart();
    if (p.grpc_server == nullptr || p.grpc_port == 0) {
        return absl::UnavailableError(
            absl::StrCat("--grpc-address: cannot listen on ", o.grpc_address));
    }
    absl::StatusOr<int> http_port = p.gateway->Start();
    if (!http_port.ok()) {
        p.grpc_server->Shutdown();
        return http_port.status();
    }
    p.http_port = *http_port;
    return std::unique_ptr<Server>(new Server(std::move(parts)));
}

int Server::grpc_port() const { return parts_->grpc_port; }
int Server::http_port() const { return parts_->http_port; }

void Server::Shutdown() {
    Parts& p = *parts_;
    {
        std::lock_guard<std::mutex> lock(p.mutex);
        if (p.stopping) return;
        p.stopping = true;
    }
    const auto grace =
        std::chrono::milliseconds(static_cast<long long>(p.options.shutdown_grace_s * 1000.0));
    LogEvent(LogLevel::kInfo, "shutting down",
             {{"grace_s", p.options.shutdown_grace_s},
              {"queued", p.pool->queued()},
              {"running", p.pool->running()}});
    // Readiness first, so that load balancers stop sending; then no new calls; then the work
    // in flight finishes (or is refused once the grace period is over).
    p.health->BeginShutdown();
    p.gateway->BeginShutdown();
    p.grpc_server->Shutdown(std::chrono::system_clock::now() + grace);
    const bool drained = p.pool->Shutdown(grace);
    p.gateway->Stop();
    LogEvent(drained ? LogLevel::kInfo : LogLevel::kWarn, "stopped",
             {{"drained", drained ? "yes" : "no, queued calls were refused"}});
    {
        std::lock_guard<std::mutex> lock(p.mutex);
        p.stopped = true;
    }
    p.stopped_cv.notify_all();
}

void Server::Wait() {
    std::unique_lock<std::mutex> lock(parts_->mutex);
    parts_->stopped_cv.wait(lock, [this] { return parts_->stopped; });
}

}  // namespace soilvol::server
