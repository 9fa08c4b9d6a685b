#include "server/metrics.hpp"

#include "core/common/build_info.hpp"
#include "prometheus/counter.h"
#include "prometheus/gauge.h"
#include "prometheus/histogram.h"
#include "prometheus/registry.h"
#include "prometheus/text_serializer.h"
#include "server/status_map.hpp"

namespace soilvol::server {
namespace {

// 1 ms to ~65 s, doubling.
prometheus::Histogram::BucketBoundaries LatencyBuckets() {
    prometheus::Histogram::BucketBoundaries buckets;
    for (double b = 0.001; b < 70.0; b *= 2.0) buckets.push_back(b);
    return buckets;
}

}  // namespace

struct Metrics::Impl {
    std::shared_ptr<prometheus::Registry> registry = std::make_shared<prometheus::Registry>();
    prometheus::Family<prometheus::Counter>& requests =
        prometheus::BuildCounter()
            .Name("soilvol_requests_total")
            .Help("Requests answered, by RPC, gRPC status code and transport")
            .Register(*registry);
    prometheus::Family<prometheus::Histogram>& latency =
        prometheus::BuildHistogram()
            .Name("soilvol_request_duration_seconds")
            .Help("Time from a request's arrival to its answer, by RPC")
            .Register(*registry);
    prometheus::Family<prometheus::Histogram>& stages =
        prometheus::BuildHistogram()
            .Name("soilvol_stage_duration_seconds")
            .Help("Time per pipeline stage of calibrations, registrations and estimates")
            .Register(*registry);
    prometheus::Gauge& in_flight = MakeGauge("soilvol_in_flight", "Requests running on a worker");
    prometheus::Gauge& queue_depth =
        MakeGauge("soilvol_queue_depth", "Requests waiting for a worker");
    prometheus::Gauge& workers = MakeGauge("soilvol_workers", "Engine worker threads");
    prometheus::Gauge& max_queue =
        MakeGauge("soilvol_max_queue", "Requests that may wait for a worker before refusals");

    prometheus::Gauge& build_info = prometheus::BuildGauge()
                                        .Name("soilvol_build_info")
                                        .Help("1, labelled with the server's version and build")
                                        .Register(*registry)
                                        .Add({{"version", GetBuildInfo().version},
                                              {"revision", GetBuildInfo().revision},
                                              {"build_type", GetBuildInfo().build_type}});

    prometheus::Gauge& MakeGauge(const std::string& name, const std::string& help) {
        return prometheus::BuildGauge().Name(name).Help(help).Register(*registry).Add({});
    }
};

Metrics::Metrics() : impl_(std::make_unique<Impl>()) { impl_->build_info.Set(1.0); }

Metrics::~Metrics() = default;

void Metrics::RecordRequest(std::string_view method, std::string_view transport,
                            absl::StatusCode code, double seconds) {
    impl_->requests
        .Add({{"method", std::string(method)},
              {"code", std::string(CodeName(code))},
              {"transport", std::string(transport)}})
        .Increment();
    impl_->latency.Add({{"method", std::string(method)}}, LatencyBuckets()).Observe(seconds);
}

void Metrics::RecordStage(std::string_view stage, double seconds) {
    impl_->stages.Add({{"stage", std::string(stage)}}, LatencyBuckets()).Observe(seconds);
}

void Metrics::SetLoad(double in_flight, double queued) {
    impl_->in_flight.Set(in_flight);
    impl_->queue_depth.Set(queued);
}

void Metrics::SetWorkers(int workers, int max_queue) {
    impl_->workers.Set(workers);
    impl_->max_queue.Set(max_queue);
}

std::string Metrics::Serialize() const {
    return prometheus::TextSerializer().Serialize(impl_->registry->Collect());
}

}  // namespace soilvol::server
