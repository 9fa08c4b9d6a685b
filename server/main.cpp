// soilvol-server: flags (or SOILVOL_* variables) -> ServerOptions -> Server; SIGTERM/SIGINT
// stop it gracefully.
#include <pthread.h>

#include <csignal>
#include <iostream>
#include <thread>

#include "CLI/CLI.hpp"
#include "server/cpu_budget.hpp"
#include "server/logging.hpp"
#include "server/options.hpp"
#include "server/server.hpp"

namespace {

using soilvol::server::LogEvent;
using soilvol::server::LogLevel;

soilvol::server::ServerOptions ParseFlags(CLI::App& app, int argc, char** argv) {
    soilvol::server::ServerOptions o;
    app.add_option("--grpc-address", o.grpc_address,
                   "gRPC listen address (host:port, port 0 = any)")
        ->envname("SOILVOL_GRPC_ADDRESS")
        ->capture_default_str();
    app.add_option("--http-address", o.http_address, "REST, health and metrics listen address")
        ->envname("SOILVOL_HTTP_ADDRESS")
        ->capture_default_str();
    app.add_option("--data-dir", o.data_dir, "Directory of container models and calibrations")
        ->envname("SOILVOL_DATA_DIR")
        ->capture_default_str();
    app.add_option("--workers", o.workers,
                   "Calls run at once (0 = one per CPU of the cgroup limit); each gets 2 x CPUs / "
                   "workers threads, at most the CPUs")
        ->envname("SOILVOL_WORKERS")
        ->capture_default_str();
    app.add_option(
           "--max-queue", o.max_queue,
           "Requests that may wait for a worker before RESOURCE_EXHAUSTED (0 = 4 x workers)")
        ->envname("SOILVOL_MAX_QUEUE")
        ->capture_default_str();
    app.add_option("--max-message-mb", o.max_message_mb, "Largest request [MiB]")
        ->envname("SOILVOL_MAX_MESSAGE_MB")
        ->capture_default_str();
    app.add_option("--log-level", o.log_level, "trace, debug, info, warn, error, critical, off")
        ->envname("SOILVOL_LOG_LEVEL")
        ->capture_default_str();
    app.add_option("--log-format", o.log_format, "text or json")
        ->envname("SOILVOL_LOG_FORMAT")
        ->capture_default_str();
    app.add_option("--cors-origin", o.cors_origins,
                   "Browser origin allowed to call the REST API (repeat; * for any)")
        ->envname("SOILVOL_CORS_ORIGINS")
        ->delimiter(',');
    app.add_option("--shutdown-grace-s", o.shutdown_grace_s,
                   "Seconds in-flight calls get to finish on SIGTERM")
        ->envname("SOILVOL_SHUTDOWN_GRACE_S")
        ->capture_default_str();
    app.add_option("--http-threads", o.http_threads, "REST connections served at once")
        ->envname("SOILVOL_HTTP_THREADS")
        ->capture_default_str();
    app.parse(argc, argv);
    return o;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"soilvol-server: volume of soil in containers, over gRPC and REST"};
    soilvol::server::ServerOptions options;
    try {
        options = ParseFlags(app, argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e);
    }
    if (absl::Status s = soilvol::server::ValidateOptions(options); !s.ok()) {
        std::cerr << "soilvol-server: " << s.message() << "\n";
        return 2;
    }
    if (absl::Status s = soilvol::server::ConfigureLogging(options.log_level, options.log_format);
        !s.ok()) {
        std::cerr << "soilvol-server: " << s.message() << "\n";
        return 2;
    }
    // Signals go to one thread that asks the server to stop; every other thread blocks them.
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    absl::StatusOr<std::unique_ptr<soilvol::server::Server>> server =
        soilvol::server::Server::BuildAndStart(options);
    if (!server.ok()) {
        LogEvent(LogLevel::kError, "cannot start", {{"error", server.status().message()}});
        return absl::IsInvalidArgument(server.status()) ? 2 : 1;
    }
    const soilvol::server::ServerOptions resolved = soilvol::server::ResolveOptions(options);
    LogEvent(
        LogLevel::kInfo, "listening",
        {{"grpc_port", (*server)->grpc_port()},
         {"http_port", (*server)->http_port()},
         {"grpc_address", resolved.grpc_address},
         {"http_address", resolved.http_address},
         {"data_dir", resolved.data_dir},
         {"cpus", resolved.cpus},
         {"workers", resolved.workers},
         {"threads_per_call", soilvol::server::ThreadsPerCall(resolved.cpus, resolved.workers)},
         {"max_queue", resolved.max_queue}});
    std::thread waiter([&server, &signals] {
        int signal = 0;
        sigwait(&signals, &signal);
        LogEvent(LogLevel::kInfo, "signal", {{"signal", signal == SIGTERM ? "SIGTERM" : "SIGINT"}});
        (*server)->Shutdown();
    });
    (*server)->Wait();
    waiter.join();
    return 0;
}
