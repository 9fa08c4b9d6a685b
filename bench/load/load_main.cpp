// soilvol-load: round trips and throughput of a running soilvol-server, over gRPC or REST, from
// simulated scans of the paper bucket (the speed table's scenes). Registers the container
// through the API, then runs `--clients` closed-loop clients for `--seconds` and prints the
// figures: requests/s, latency percentiles, the server's own stage timings, and every status
// that was not OK.
#include <grpcpp/grpcpp.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_format.h"
#include "bench/trial.hpp"
#include "core/common/build_info.hpp"
#include "core/common/statistics.hpp"
#include "core/io/cloud_codec.hpp"
#include "google/protobuf/util/json_util.h"
#include "soilvol/v1/soilvol.grpc.pb.h"

namespace soilvol::bench {
namespace {

namespace beast = boost::beast;
namespace http = beast::http;
using tcp = boost::asio::ip::tcp;
using Clock = std::chrono::steady_clock;

struct Options {
    std::string grpc_address = "127.0.0.1:50051";
    std::string http_address = "127.0.0.1:8080";
    std::string transport = "grpc";
    int clients = 1;
    std::size_t points = 100000;
    double seconds = 10.0;
    double warmup_s = 2.0;
    std::string container = "load-bucket";
};

// One call's outcome.
struct Call {
    double ms = 0.0;
    std::string status;  // "OK" or the status name / HTTP code
    v1::Timings timings;
};

// A client: one connection, one call at a time.
class Client {
  public:
    virtual ~Client() = default;
    virtual Call Estimate() = 0;
};

class GrpcClient : public Client {
  public:
    GrpcClient(const std::string& address, const v1::EstimateVolumeRequest& request)
        : request_(request) {
        // A channel each: clients share no HTTP/2 connection, as separate machines would not.
        grpc::ChannelArguments args;
        args.SetMaxReceiveMessageSize(64 << 20);
        args.SetMaxSendMessageSize(64 << 20);
        args.SetInt("grpc.use_local_subchannel_pool", 1);
        stub_ = v1::SoilVolume::NewStub(
            grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args));
    }
    Call Estimate() override {
        grpc::ClientContext context;
        context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
        v1::EstimateVolumeResponse response;
        const auto start = Clock::now();
        const grpc::Status status = stub_->EstimateVolume(&context, request_, &response);
        Call call;
        call.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
        call.status = status.ok() ? "OK" : absl::StrFormat("gRPC %d", status.error_code());
        call.timings = response.timings();
        return call;
    }

  private:
    const v1::EstimateVolumeRequest& request_;
    std::unique_ptr<v1::SoilVolume::Stub> stub_;
};

// REST through the gateway's JSON mapping (base64 bytes), over one kept-alive connection.
class RestClient : public Client {
  public:
    RestClient(const std::string& address, const std::string& container, std::string body)
        : body_(std::move(body)) {
        const auto colon = address.rfind(':');
        host_ = address.substr(0, colon);
        port_ = address.substr(colon + 1);
        target_ = "/v1/containers/" + container + ":estimate";
    }
    Call Estimate() override {
        Call call;
        const auto start = Clock::now();
        try {
            if (!stream_) Connect();
            http::request<http::string_body> request{http::verb::post, target_, 11};
            request.set(http::field::host, host_);
            request.set(http::field::content_type, "application/json");
            request.keep_alive(true);
            request.body() = body_;
            request.prepare_payload();
            http::write(*stream_, request);
            http::response<http::string_body> response;
            http::read(*stream_, buffer_, response);
            call.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
            if (response.result() != http::status::ok) {
                call.status = absl::StrFormat("HTTP %d", response.result_int());
            } else {
                v1::EstimateVolumeResponse parsed;
                google::protobuf::util::JsonParseOptions options;
                options.ignore_unknown_fields = true;
                const auto ok =
                    google::protobuf::util::JsonStringToMessage(response.body(), &parsed, options);
                call.status = ok.ok() ? "OK" : "bad JSON";
                call.timings = parsed.timings();
            }
            if (!response.keep_alive()) stream_.reset();
        } catch (const std::exception& e) {
            call.ms = std::chrono::duration<double, std::milli>(Clock::now() - start).count();
            call.status = std::string("connection: ") + e.what();
            stream_.reset();
        }
        return call;
    }

  private:
    void Connect() {
        tcp::resolver resolver(io_);
        stream_ = std::make_unique<beast::tcp_stream>(io_);
        stream_->connect(resolver.resolve(host_, port_));
        stream_->socket().set_option(tcp::no_delay(true));
    }

    boost::asio::io_context io_;
    std::unique_ptr<beast::tcp_stream> stream_;
    beast::flat_buffer buffer_;
    std::string host_, port_, target_, body_;
};

v1::Point3 ToPoint(const Eigen::Vector3d& p) {
    v1::Point3 out;
    out.set_x(p.x());
    out.set_y(p.y());
    out.set_z(p.z());
    return out;
}

bool Register(const Options& options) {
    Setup setup;
    setup.sensor = PaperSensor(setup.container);
    const EmptyScanCase empty = SimulateEmpty(setup, 1);
    v1::RegisterContainerRequest request;
    request.set_container_id(options.container);
    request.set_overwrite(true);
    request.mutable_scan()->mutable_cloud()->set_data(io::EncodePly(empty.scene.points));
    for (const auto& c : empty.corners) *request.mutable_opening()->add_corners() = ToPoint(c);
    auto stub = v1::SoilVolume::NewStub(
        grpc::CreateChannel(options.grpc_address, grpc::InsecureChannelCredentials()));
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    v1::Container container;
    const grpc::Status status = stub->RegisterContainer(&context, request, &container);
    if (!status.ok()) std::cerr << "register: " << status.error_message() << "\n";
    return status.ok();
}

struct Figures {
    std::vector<double> ms;
    std::map<std::string, int> statuses;
    std::vector<double> preprocess, align, volume, queue, server_total;
};

int Run(const Options& options) {
    if (!Register(options)) return 1;
    const SizedScene sized = SceneOfAbout(options.points, 1);
    v1::EstimateVolumeRequest request;
    request.set_container_id(options.container);
    request.mutable_scan()->mutable_cloud()->set_data(io::EncodePly(sized.scene.points));
    std::string json;
    if (!google::protobuf::util::MessageToJsonString(request, &json).ok()) return 1;
    std::vector<std::unique_ptr<Client>> clients;
    for (int c = 0; c < options.clients; ++c) {
        if (options.transport == "rest") {
            clients.push_back(
                std::make_unique<RestClient>(options.http_address, options.container, json));
        } else {
            clients.push_back(std::make_unique<GrpcClient>(options.grpc_address, request));
        }
    }
    std::mutex mutex;
    Figures figures;
    const auto begin = Clock::now();
    const auto measure_from = begin + std::chrono::duration<double>(options.warmup_s);
    const auto end = measure_from + std::chrono::duration<double>(options.seconds);
    std::vector<std::thread> threads;
    for (auto& client : clients) {
        threads.emplace_back([&, c = client.get()] {
            while (Clock::now() < end) {
                const auto started = Clock::now();
                const Call call = c->Estimate();
                if (started < measure_from || Clock::now() > end) continue;
                const std::lock_guard<std::mutex> lock(mutex);
                figures.ms.push_back(call.ms);
                ++figures.statuses[call.status];
                if (call.status != "OK") continue;
                figures.preprocess.push_back(call.timings.preprocess_ms());
                figures.align.push_back(call.timings.align_ms());
                figures.volume.push_back(call.timings.volume_ms());
                figures.queue.push_back(call.timings.queue_ms());
                figures.server_total.push_back(call.timings.total_ms());
            }
        });
    }
    for (auto& t : threads) t.join();
    if (figures.ms.empty()) {
        std::cerr << "no call finished inside the measured window\n";
        return 1;
    }
    const auto median = [](std::vector<double> v) { return v.empty() ? 0.0 : Median(v); };
    const auto quantile = [](std::vector<double> v, double q) {
        return v.empty() ? 0.0 : QuantileInPlace(v, q);
    };
    int ok = figures.statuses.count("OK") ? figures.statuses.at("OK") : 0;
    std::string others;
    for (const auto& [status, count] : figures.statuses) {
        if (status != "OK")
            others += absl::StrFormat("%s%s x%d", others.empty() ? "" : ", ", status, count);
    }
    const double rate = static_cast<double>(figures.ms.size()) / options.seconds;
    std::cout << absl::StrFormat(
        "load transport=%s clients=%d points=%zu calls=%zu ok=%d requests_per_s=%.1f "
        "p50_ms=%.1f p90_ms=%.1f p99_ms=%.1f server_total_ms=%.1f preprocess_ms=%.1f "
        "align_ms=%.1f volume_ms=%.1f queue_ms=%.1f errors=\"%s\"\n",
        options.transport, options.clients, sized.scene.points.size(), figures.ms.size(), ok, rate,
        quantile(figures.ms, 0.5), quantile(figures.ms, 0.9), quantile(figures.ms, 0.99),
        median(figures.server_total), median(figures.preprocess), median(figures.align),
        median(figures.volume), median(figures.queue), others);
    std::cout << absl::StrFormat(
        "| %s | %d | %zu | %.1f | %.1f | %.1f | %.1f | %.1f / %.1f / %.1f / %.1f | %s |\n",
        options.transport == "rest" ? "REST (JSON, base64)" : "gRPC", options.clients,
        sized.scene.points.size(), rate, quantile(figures.ms, 0.5), quantile(figures.ms, 0.99),
        median(figures.server_total), median(figures.preprocess), median(figures.align),
        median(figures.volume), median(figures.queue), others.empty() ? "none" : others);
    return 0;
}

}  // namespace
}  // namespace soilvol::bench

int main(int argc, char** argv) {
    soilvol::bench::Options options;
    CLI::App app{"soilvol-load: round trips and throughput of a running soilvol-server"};
    app.set_version_flag("--version", soilvol::VersionLine("soilvol-load"));
    app.add_option("--grpc", options.grpc_address, "server gRPC address (host:port)");
    app.add_option("--http", options.http_address, "server REST address (host:port)");
    app.add_option("--transport", options.transport, "grpc or rest")
        ->check(CLI::IsMember({"grpc", "rest"}));
    app.add_option("--clients", options.clients, "closed-loop clients, one connection each")
        ->check(CLI::Range(1, 256));
    app.add_option("--points", options.points, "points per scan (about)")
        ->check(CLI::Range(1000, 2000000));
    app.add_option("--seconds", options.seconds, "measured window [s]")
        ->check(CLI::Range(1.0, 600.0));
    app.add_option("--warmup", options.warmup_s, "calls before this are not counted [s]")
        ->check(CLI::Range(0.0, 60.0));
    app.add_option("--container", options.container, "container id to register and estimate");
    CLI11_PARSE(app, argc, argv);
    return soilvol::bench::Run(options);
}
