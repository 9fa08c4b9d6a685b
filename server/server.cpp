#include "server/server.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <random>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/pipeline/parallelism.hpp"
#include "grpcpp/ext/proto_server_reflection_plugin.h"
#include "grpcpp/grpcpp.h"
#include "grpcpp/security/server_credentials.h"
#include "grpcpp/security/tls_certificate_provider.h"
#include "grpcpp/security/tls_credentials_options.h"
#include "proto/convert/proto_convert.hpp"
#include "server/auth/authenticator.hpp"
#include "server/base/logging.hpp"
#include "server/base/periodic_task.hpp"
#include "server/dispatch/cpu_budget.hpp"
#include "server/dispatch/dispatcher.hpp"
#include "server/dispatch/metrics.hpp"
#include "server/dispatch/worker_pool.hpp"
#include "server/grpc/grpc_service.hpp"
#include "server/grpc/health_service.hpp"
#include "server/handlers/alert_rules.hpp"
#include "server/handlers/mesh_request.hpp"
#include "server/handlers/rpc_table.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/http/http_gateway.hpp"
#include "server/records/record_feed.hpp"
#include "server/records/recorder.hpp"
#include "server/store/entry_store.hpp"
#include "server/webhooks/webhook_config.hpp"
#include "server/webhooks/webhook_dispatcher.hpp"

namespace soilvol::server {

struct ServerParts {
    explicit ServerParts(ServerOptions resolved)
        : options(std::move(resolved)), metrics(options.metrics_max_containers) {}

    ServerOptions options;
    std::unique_ptr<Authenticator> authenticator;
    std::unique_ptr<EntryStore> store;
    std::unique_ptr<RecordStore> records;
    std::unique_ptr<EstimateRecorder> recorder;  // after records: stops before it closes
    std::unique_ptr<EstimateFeed> feed;          // after the recorder it waits on
    std::unique_ptr<AlertFeed> alert_feed;
    std::unique_ptr<LoadEventFeed> load_feed;
    std::vector<WebhookTarget> webhooks;
    Metrics metrics;
    std::unique_ptr<WorkerPool> pool;
    std::unique_ptr<Dispatcher> dispatcher;
    std::unique_ptr<SoilVolumeHandlers> handlers;
    std::unique_ptr<PeriodicTask> load_judge;  // after the handlers it calls
    std::unique_ptr<WebhookDispatcher> webhook_dispatcher;
    std::map<std::string, Rpc> rpcs;  // what both transports serve
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

namespace {

constexpr int kGrpcMaxStreamsPerConnection = 100;
constexpr int kGrpcHandshakeTimeoutMs = 10'000;
constexpr int kGrpcMinPingIntervalMs = 10'000;  // clients may ping every 10 s, also idle

// TLS from the files, watched for changes (cert-manager rotates them in place), with client
// certificates required and verified when a client CA is given; plaintext without files.
std::shared_ptr<grpc::ServerCredentials> GrpcCredentials(const ServerOptions& o) {
    if (o.tls_cert.empty()) return grpc::InsecureServerCredentials();
    constexpr unsigned int kRefreshS = 10;
    auto provider = o.tls_client_ca.empty()
                        ? std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
                              o.tls_key, o.tls_cert, kRefreshS)
                        : std::make_shared<grpc::experimental::FileWatcherCertificateProvider>(
                              o.tls_key, o.tls_cert, o.tls_client_ca, kRefreshS);
    grpc::experimental::TlsServerCredentialsOptions options(provider);
    options.watch_identity_key_cert_pairs();
    if (!o.tls_client_ca.empty()) {
        options.watch_root_certs();
        options.set_cert_request_type(GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY);
    } else {
        options.set_cert_request_type(GRPC_SSL_DONT_REQUEST_CLIENT_CERTIFICATE);
    }
    return grpc::experimental::TlsServerCredentials(options);
}

// Connection limits: bounded streams per connection, a handshake that must finish, a maximum
// age (GOAWAY, then a grace for the calls in flight) so clients rebalance behind a Service,
// and keepalive pings permitted every 10 s even without calls.
void ApplyConnectionLimits(const ServerOptions& o, grpc::ServerBuilder& builder) {
    builder.AddChannelArgument(GRPC_ARG_MAX_CONCURRENT_STREAMS, kGrpcMaxStreamsPerConnection);
    builder.AddChannelArgument(GRPC_ARG_SERVER_HANDSHAKE_TIMEOUT_MS, kGrpcHandshakeTimeoutMs);
    if (o.grpc_max_connection_age_s > 0.0) {
        builder.AddChannelArgument(
            GRPC_ARG_MAX_CONNECTION_AGE_MS,
            static_cast<int>(std::min(o.grpc_max_connection_age_s, 2e6) * 1e3));
        builder.AddChannelArgument(
            GRPC_ARG_MAX_CONNECTION_AGE_GRACE_MS,
            static_cast<int>(std::min(o.grpc_max_connection_age_grace_s, 2e6) * 1e3));
    }
    builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                               kGrpcMinPingIntervalMs);
    builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
}

// Debian's grpc++_reflection registers its plugin when the library loads; taking it out of
// the builder's plugins is what turns reflection off.
class WithoutReflection final : public grpc::ServerBuilderOption {
  public:
    void UpdateArguments(grpc::ChannelArguments*) override {}
    void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
        plugins->erase(std::remove_if(plugins->begin(), plugins->end(),
                                      [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
                                          return plugin->name() == "proto_server_reflection";
                                      }),
                       plugins->end());
    }
};

/// Names this process in webhook leases: host, process id and a random part.
std::string LeaseHolderName() {
    char host[256] = {};
    gethostname(host, sizeof(host) - 1);
    return absl::StrCat(host, "/", getpid(), "/", std::random_device{}());
}

MetricsAccess MetricsAccessOf(const std::string& value) {
    if (value == "off") return MetricsAccess::kOff;
    if (value == "auth") return MetricsAccess::kAuthenticated;
    return MetricsAccess::kOpen;
}

/// TLS files checked before anything listens (a bad file stops the start with its flag, path
/// and reason), and the authenticator.
absl::Status OpenSecurity(ServerParts& p) {
    const ServerOptions& o = p.options;
    if (!o.tls_cert.empty()) {
        SOILVOL_RETURN_IF_ERROR(CheckTlsFiles({o.tls_cert, o.tls_key, o.tls_client_ca}));
    }
    SOILVOL_ASSIGN_OR_RETURN(p.authenticator,
                             Authenticator::Create({o.auth_tokens_file, !o.tls_client_ca.empty()}));
    if (!o.auth_tokens_file.empty() && o.tls_cert.empty() &&
        !(IsLoopbackAddress(o.grpc_address) && IsLoopbackAddress(o.http_address))) {
        LogEvent(LogLevel::kWarn, "bearer tokens travel in clear text: no --tls-cert given",
                 {{"hint", "terminate TLS in front of the server, or give --tls-cert/--tls-key"}});
    }
    return absl::OkStatus();
}

/// The data directory, the bounded worker pool and the dispatcher over it. Busy, the workers
/// run at most two engine threads per CPU (ThreadsPerCall), for the OpenMP loops (set per
/// worker thread) and OpenCV's loops (process-wide).
absl::Status OpenEngine(ServerParts& p) {
    const ServerOptions& o = p.options;
    SOILVOL_ASSIGN_OR_RETURN(p.store, EntryStore::Open(o.data_dir));
    Metrics* metrics = &p.metrics;
    const int call_threads = ThreadsPerCall(o.cpus, o.workers);
    pipeline::SetOpenCvThreads(call_threads);
    p.pool = std::make_unique<WorkerPool>(
        o.workers, o.max_queue,
        [metrics](std::size_t running, std::size_t queued) {
            metrics->SetLoad(static_cast<double>(running), static_cast<double>(queued));
        },
        [call_threads] { pipeline::SetCallThreads(call_threads); });
    p.metrics.SetWorkers(o.workers, o.max_queue);
    p.dispatcher = std::make_unique<Dispatcher>(*p.pool, p.metrics, *p.authenticator);
    return absl::OkStatus();
}

/// The records database, its recorder and the feed that watches read (none: --records-url none).
absl::Status OpenRecords(ServerParts& p) {
    const ServerOptions& o = p.options;
    if (o.records_url == "none") {
        if (o.webhooks_file.empty()) return absl::OkStatus();
        return absl::InvalidArgumentError(
            "--webhooks-file: webhooks post the alerts kept with the records: not with "
            "--records-url none");
    }
    SOILVOL_ASSIGN_OR_RETURN(p.records, OpenRecordStore(o.records_url, o.data_dir));
    EstimateRecorder::Config recording;
    recording.retention.max_per_container = o.records_max_per_container;
    recording.retention.max_age =
        std::chrono::seconds(static_cast<long long>(o.records_max_age_days * 86400.0));
    p.recorder = std::make_unique<EstimateRecorder>(*p.records, recording);
    EstimateFeed::Config feed;
    feed.max_watches = static_cast<std::size_t>(o.max_watches);
    feed.heartbeat = std::chrono::milliseconds(std::lround(o.watch_heartbeat_s * 1000.0));
    feed.coalesce = std::chrono::milliseconds(std::lround(o.watch_coalesce_s * 1000.0));
    feed.in_use = std::make_shared<std::atomic<std::size_t>>(0);  // one limit for the three
    p.feed = std::make_unique<EstimateFeed>(*p.recorder, EstimateSource(*p.records), feed);
    p.alert_feed = std::make_unique<AlertFeed>(*p.recorder, AlertSource(*p.records), feed);
    p.load_feed = std::make_unique<LoadEventFeed>(*p.recorder, LoadEventSource(*p.records), feed);
    if (!o.webhooks_file.empty()) {
        SOILVOL_ASSIGN_OR_RETURN(p.webhooks, LoadWebhooks(o.webhooks_file));
    }
    p.metrics.SetRecordsProbe(
        p.records->kind(), [recorder = p.recorder.get(), estimates = p.feed.get(),
                            alerts = p.alert_feed.get(), loads = p.load_feed.get()] {
            const EstimateRecorder::Stats stats = recorder->stats();
            return Metrics::RecordFigures{stats.records,     stats.batches,   stats.failures,
                                          stats.pruned,      stats.queued,    estimates->watches(),
                                          alerts->watches(), loads->watches()};
        });
    return absl::OkStatus();
}

std::size_t MessageBytes(const ServerOptions& o) {
    return static_cast<std::size_t>(o.max_message_mb) << 20;
}

/// The handlers, the RPC table (checked against the proto's service) and the gRPC services.
absl::Status MakeServices(ServerParts& p, const google::protobuf::ServiceDescriptor& api) {
    HandlerOptions handling;
    handling.capacity_warning_share = p.options.capacity_warning_share;
    handling.mesh_budget = MeshBudgetFor(MessageBytes(p.options));
    handling.load_idle_us = static_cast<std::int64_t>(p.options.load_idle_s * 1e6);
    handling.site_time_zone = p.options.site_time_zone;
    handling.shift_starts = p.options.shift_starts;
    SOILVOL_ASSIGN_OR_RETURN(handling.alert_rules, ParseAlertRules(p.options.alert_rules));
    for (const WebhookTarget& target : p.webhooks) handling.webhooks.push_back(target.config);
    p.handlers = std::make_unique<SoilVolumeHandlers>(*p.store, p.recorder.get(), p.feed.get(),
                                                      p.alert_feed.get(), p.load_feed.get(),
                                                      std::move(handling));
    p.rpcs = MakeRpcTable(*p.handlers);
    SOILVOL_RETURN_IF_ERROR(CheckRpcTable(p.rpcs, api));
    SoilVolumeHandlers* handlers = p.handlers.get();
    p.health = std::make_unique<HealthService>([handlers] { return handlers->CheckReady().ok(); });
    p.service = std::make_unique<SoilVolumeService>(p.rpcs, *p.handlers, *p.dispatcher);
    return absl::OkStatus();
}

HttpGatewayOptions GatewayOptions(const ServerOptions& o) {
    HttpGatewayOptions http;
    http.server.address = o.http_address;
    http.server.io_threads = o.http_threads;
    HttpLimits& limits = http.server.limits;
    // base64 plus the JSON around it
    limits.max_body_bytes = MessageBytes(o) / 3 * 4 + (1u << 20);
    // Bodies received or held at once: those the workers and the queue can take, and two more.
    limits.max_inflight_body_bytes =
        limits.max_body_bytes * static_cast<std::uint64_t>(o.workers + o.max_queue + 2);
    limits.max_connections = static_cast<std::size_t>(o.http_max_connections);
    limits.header_timeout =
        std::chrono::milliseconds(static_cast<long long>(o.http_header_timeout_s * 1000.0));
    limits.idle_timeout =
        std::chrono::milliseconds(static_cast<long long>(o.http_idle_timeout_s * 1000.0));
    http.server.tls = {o.tls_cert, o.tls_key, o.tls_client_ca};
    http.cors_origins = o.cors_origins;
    http.metrics = MetricsAccessOf(o.metrics);
    http.probe_address = o.probe_address;
    return http;
}

/// The REST gateway over the proto's routes; a route nothing serves stops the start (it would
/// answer 500).
absl::Status MakeGateway(ServerParts& p, const google::protobuf::ServiceDescriptor& api) {
    SOILVOL_ASSIGN_OR_RETURN(std::vector<HttpRoute> routes, RoutesFromAnnotations(api));
    std::map<std::string, StreamRpc> streams = MakeStreamTable(*p.handlers);
    for (const HttpRoute& route : routes) {
        if (p.rpcs.count(route.method) == 0 && streams.count(route.method) == 0) {
            return absl::InternalError(
                absl::StrCat("REST route ", route.pattern, " (", route.method, ") has no handler"));
        }
    }
    HealthService* health = p.health.get();
    p.gateway = std::make_unique<HttpGateway>(
        GatewayOptions(p.options), p.rpcs, std::move(streams), std::move(routes), *p.dispatcher,
        p.metrics, [health] {
            return health->StatusOf("") == grpc::health::v1::HealthCheckResponse::SERVING;
        });
    return absl::OkStatus();
}

/// soilvol_alerts_total{kind} (what this server raised: with its records, and its judge's) and
/// soilvol_loads_closed_total{load_status} (the loads its judge closed or found closed).
void AddAlertMetrics(ServerParts& p) {
    EstimateRecorder* recorder = p.recorder.get();
    SoilVolumeHandlers* handlers = p.handlers.get();
    p.metrics.AddCounterProbe(
        "soilvol_alerts_total", "Alerts this server raised, by kind", [recorder, handlers] {
            std::array<std::uint64_t, 6> by_kind = recorder->stats().alerts;
            by_kind[AlertRecord::kLoadOffTarget] += handlers->judge_figures().load_alerts;
            std::vector<Metrics::ProbedValue> out;
            for (int kind = 1; kind < static_cast<int>(by_kind.size()); ++kind) {
                out.push_back({{{"kind", AlertKindLabel(kind)}},
                               static_cast<double>(by_kind[static_cast<std::size_t>(kind)])});
            }
            return out;
        });
    p.metrics.AddCounterProbe(
        "soilvol_loads_closed_total",
        "Truck loads whose close this server judged, by the status of their total", [handlers] {
            const auto closed = handlers->judge_figures().loads_closed;
            std::vector<Metrics::ProbedValue> out;
            for (int status = 1; status < static_cast<int>(closed.size()); ++status) {
                std::string name = v1::LoadStatus_Name(static_cast<v1::LoadStatus>(status));
                name = absl::AsciiStrToLower(name.substr(std::string("LOAD_STATUS_").size()));
                out.push_back({{{"load_status", name}},
                               static_cast<double>(closed[static_cast<std::size_t>(status)])});
            }
            return out;
        });
}

/// What runs beside the calls: the judge of closed loads (every second) and the webhooks.
void StartBackground(ServerParts& p) {
    if (p.recorder == nullptr) return;
    SoilVolumeHandlers* handlers = p.handlers.get();
    p.load_judge = std::make_unique<PeriodicTask>(std::chrono::seconds(1), [handlers] {
        const absl::StatusOr<int> judged = handlers->JudgeLoads(NowMicros());
        if (!judged.ok()) {
            LogEvent(LogLevel::kWarn, "judging closed loads failed",
                     {{"error", judged.status().message()}});
        }
    });
    AddAlertMetrics(p);
    if (p.webhooks.empty()) return;
    WebhookDispatcher::Config config;
    config.max_age = std::chrono::seconds(std::lround(p.options.webhook_max_age_hours * 3600.0));
    config.post.ca_file = p.options.webhook_ca_file;
    config.lease = std::chrono::seconds(p.options.webhook_lease_s);
    config.holder = LeaseHolderName();
    p.webhook_dispatcher =
        std::make_unique<WebhookDispatcher>(*p.recorder, p.webhooks, std::move(config));
    WebhookDispatcher* dispatcher = p.webhook_dispatcher.get();
    p.metrics.AddCounterProbe(
        "soilvol_webhook_deliveries_total",
        "Attempts to post an alert to a webhook, by webhook and outcome", [dispatcher] {
            std::vector<Metrics::ProbedValue> out;
            for (const auto& [webhook, counts] : dispatcher->counts()) {
                for (const auto& [outcome, n] :
                     {std::pair<const char*, std::uint64_t>{"delivered", counts.delivered},
                      {"failed", counts.failed},
                      {"abandoned", counts.abandoned}}) {
                    out.push_back(
                        {{{"webhook", webhook}, {"outcome", outcome}}, static_cast<double>(n)});
                }
            }
            return out;
        });
}

/// Binds and starts gRPC, then REST; Unavailable naming the flag of an address not bound.
absl::Status StartListening(ServerParts& p) {
    const ServerOptions& o = p.options;
    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
    grpc::ServerBuilder builder;
    if (!o.reflection) builder.SetOption(std::make_unique<WithoutReflection>());
    builder.AddListeningPort(o.grpc_address, GrpcCredentials(o), &p.grpc_port);
    ApplyConnectionLimits(o, builder);
    builder.SetMaxReceiveMessageSize(static_cast<int>(MessageBytes(o)));
    builder.SetMaxSendMessageSize(static_cast<int>(MessageBytes(o)));
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
    return absl::OkStatus();
}

}  // namespace

absl::StatusOr<std::unique_ptr<Server>> Server::BuildAndStart(const ServerOptions& raw) {
    SOILVOL_RETURN_IF_ERROR(ValidateOptions(raw));
    auto parts = std::make_unique<ServerParts>(ResolveOptions(raw));
    const google::protobuf::ServiceDescriptor* api =
        google::protobuf::DescriptorPool::generated_pool()->FindServiceByName(
            "soilvol.v1.SoilVolume");
    if (api == nullptr) return absl::InternalError("soilvol.v1.SoilVolume is not linked in");
    SOILVOL_RETURN_IF_ERROR(OpenSecurity(*parts));
    SOILVOL_RETURN_IF_ERROR(OpenEngine(*parts));
    SOILVOL_RETURN_IF_ERROR(OpenRecords(*parts));
    SOILVOL_RETURN_IF_ERROR(MakeServices(*parts, *api));
    SOILVOL_RETURN_IF_ERROR(MakeGateway(*parts, *api));
    SOILVOL_RETURN_IF_ERROR(StartListening(*parts));
    StartBackground(*parts);
    return std::unique_ptr<Server>(new Server(std::move(parts)));
}

Server::Server(std::unique_ptr<ServerParts> parts) : parts_(std::move(parts)) {}

Server::~Server() { Shutdown(); }

int Server::grpc_port() const { return parts_->grpc_port; }
int Server::http_port() const { return parts_->http_port; }
int Server::probe_port() const { return parts_->gateway->probe_port(); }

const char* Server::records_kind() const {
    return parts_->records != nullptr ? parts_->records->kind() : "none";
}

void Server::Shutdown() {
    ServerParts& p = *parts_;
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
    // in flight finishes. Once the grace period is over, what still runs is stopped at its
    // next check (StopToken) and what still waits is refused.
    const auto wall_deadline = std::chrono::system_clock::now() + grace;
    const auto deadline = Clock::now() + grace;
    p.health->BeginShutdown();
    p.gateway->BeginShutdown();
    // Watches never end by themselves: end them (UNAVAILABLE; clients resume elsewhere) so
    // that the transports need not wait for them.
    if (p.feed != nullptr) p.feed->Shutdown();
    if (p.alert_feed != nullptr) p.alert_feed->Shutdown();
    if (p.load_feed != nullptr) p.load_feed->Shutdown();
    p.grpc_server->Shutdown(wall_deadline);
    const auto left = std::max(Clock::duration::zero(), deadline - Clock::now());
    Dispatcher* dispatcher = p.dispatcher.get();
    const bool drained =
        p.pool->Shutdown(std::chrono::duration_cast<std::chrono::milliseconds>(left),
                         [dispatcher] { dispatcher->StopAll(); });
    // Estimates the workers finished may still wait for their records' commit: answer them
    // while the transports and the dispatcher are there.
    if (p.recorder != nullptr) p.recorder->Flush();
    p.gateway->Stop();
    // No call waits on these: they stop after the transports (a post in flight may take its
    // timeout), before the records close.
    p.load_judge.reset();
    if (p.webhook_dispatcher != nullptr) p.webhook_dispatcher->Shutdown();
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
