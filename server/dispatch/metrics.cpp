#include "server/dispatch/metrics.hpp"

#include <algorithm>
#include <mutex>
#include <set>
#include <vector>

#include "core/common/build_info.hpp"
#include "prometheus/counter.h"
#include "prometheus/gauge.h"
#include "prometheus/histogram.h"
#include "prometheus/registry.h"
#include "prometheus/text_serializer.h"
#include "server/base/process_stats.hpp"
#include "server/base/status_map.hpp"

namespace soilvol::server {
namespace {

// 1 ms to ~65 s, doubling.
prometheus::Histogram::BucketBoundaries LatencyBuckets() {
    prometheus::Histogram::BucketBoundaries buckets;
    for (double b = 0.001; b < 70.0; b *= 2.0) buckets.push_back(b);
    return buckets;
}

prometheus::MetricFamily OneValue(const std::string& name, const std::string& help,
                                  prometheus::MetricType type, double value) {
    prometheus::ClientMetric metric;
    if (type == prometheus::MetricType::Counter) {
        metric.counter.value = value;
    } else {
        metric.gauge.value = value;
    }
    prometheus::MetricFamily family;
    family.name = name;
    family.help = help;
    family.type = type;
    family.metric.push_back(metric);
    return family;
}

// Prometheus's process_* names (client libraries' process collector), from /proc.
void AppendProcessFamilies(const ProcessStats& s, std::vector<prometheus::MetricFamily>& out) {
    using prometheus::MetricType;
    out.push_back(OneValue("process_cpu_seconds_total", "Total user and system CPU time spent",
                           MetricType::Counter, s.cpu_seconds));
    out.push_back(OneValue("process_resident_memory_bytes", "Resident memory size in bytes",
                           MetricType::Gauge, s.resident_bytes));
    out.push_back(OneValue("process_virtual_memory_bytes", "Virtual memory size in bytes",
                           MetricType::Gauge, s.virtual_bytes));
    out.push_back(OneValue("process_start_time_seconds",
                           "Start time of the process since the Unix epoch in seconds",
                           MetricType::Gauge, s.start_time_s));
    out.push_back(OneValue("process_open_fds", "Number of open file descriptors", MetricType::Gauge,
                           s.open_fds));
    out.push_back(OneValue("process_max_fds", "Maximum number of open file descriptors",
                           MetricType::Gauge, s.max_fds));
}

}  // namespace

struct Metrics::Impl {
    explicit Impl(int max_containers_) : max_containers(max_containers_) {}

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

    prometheus::Family<prometheus::Counter>& estimates =
        prometheus::BuildCounter()
            .Name("soilvol_estimates_total")
            .Help("Estimates answered, by container and load status against its targets")
            .Register(*registry);
    prometheus::Family<prometheus::Counter>& volume =
        prometheus::BuildCounter()
            .Name("soilvol_estimated_volume_cubic_meters_total")
            .Help("Loose volume of the answered estimates, by container")
            .Register(*registry);
    prometheus::Family<prometheus::Counter>& bank_volume =
        prometheus::BuildCounter()
            .Name("soilvol_estimated_bank_volume_cubic_meters_total")
            .Help("In-place (bank) volume of the answered estimates, by container")
            .Register(*registry);
    prometheus::Family<prometheus::Counter>& mass =
        prometheus::BuildCounter()
            .Name("soilvol_estimated_mass_kilograms_total")
            .Help("Mass of the answered estimates whose material has a density, by container")
            .Register(*registry);
    const int max_containers;
    std::mutex containers_mutex;
    std::set<std::string> labelled;  ///< the containers with a label of their own

    /// `container`, or "_other" once max_containers others have a label.
    std::string ContainerLabel(std::string_view container) {
        std::lock_guard<std::mutex> lock(containers_mutex);
        std::string name(container);
        if (labelled.count(name) != 0) return name;
        if (labelled.size() >= static_cast<std::size_t>(max_containers)) return "_other";
        labelled.insert(name);
        return name;
    }

    struct CounterProbe {
        std::string name, help;
        std::function<std::vector<Metrics::ProbedValue>()> read;
    };
    std::vector<CounterProbe> counter_probes;  // set before the first scrape

    /// The probed counter families as they are now.
    void AppendProbed(std::vector<prometheus::MetricFamily>& out) const {
        for (const CounterProbe& probe : counter_probes) {
            prometheus::MetricFamily family;
            family.name = probe.name;
            family.help = probe.help;
            family.type = prometheus::MetricType::Counter;
            for (const Metrics::ProbedValue& value : probe.read()) {
                prometheus::ClientMetric metric;
                for (const auto& [key, label] : value.labels) metric.label.push_back({key, label});
                metric.counter.value = value.value;
                family.metric.push_back(std::move(metric));
            }
            out.push_back(std::move(family));
        }
    }

    std::function<Metrics::RecordFigures()> records_probe;
    std::mutex records_mutex;             // one scrape at a time moves the counters
    Metrics::RecordFigures records_seen;  // what the counters hold
    prometheus::Counter* records_written = nullptr;
    prometheus::Counter* record_batches = nullptr;
    prometheus::Counter* record_failures = nullptr;
    prometheus::Counter* records_pruned = nullptr;
    prometheus::Gauge* records_queued = nullptr;
    prometheus::Gauge* estimate_watches = nullptr;
    prometheus::Gauge* alert_watches = nullptr;
    prometheus::Gauge* load_watches = nullptr;

    prometheus::Counter& MakeCounter(const std::string& name, const std::string& help,
                                     const std::string& store) {
        return prometheus::BuildCounter().Name(name).Help(help).Register(*registry).Add(
            {{"store", store}});
    }

    /// The counters moved up to what the probe reports now (counters only grow).
    void ReadRecords() {
        if (!records_probe) return;
        const Metrics::RecordFigures now = records_probe();
        std::lock_guard<std::mutex> lock(records_mutex);
        const auto advance = [](prometheus::Counter* counter, std::uint64_t& seen,
                                std::uint64_t value) {
            if (value > seen) counter->Increment(static_cast<double>(value - seen));
            seen = std::max(seen, value);
        };
        advance(records_written, records_seen.written, now.written);
        advance(record_batches, records_seen.batches, now.batches);
        advance(record_failures, records_seen.failures, now.failures);
        advance(records_pruned, records_seen.pruned, now.pruned);
        records_queued->Set(static_cast<double>(now.queued));
        estimate_watches->Set(static_cast<double>(now.estimate_watches));
        alert_watches->Set(static_cast<double>(now.alert_watches));
        load_watches->Set(static_cast<double>(now.load_watches));
    }

    prometheus::Gauge& MakeGauge(const std::string& name, const std::string& help) {
        return prometheus::BuildGauge().Name(name).Help(help).Register(*registry).Add({});
    }
};

Metrics::Metrics(int max_containers) : impl_(std::make_unique<Impl>(max_containers)) {
    impl_->build_info.Set(1.0);
}

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

void Metrics::RecordEstimate(std::string_view container, std::string_view load_status,
                             double volume_m3, double bank_volume_m3,
                             std::optional<double> mass_kg) {
    Impl& m = *impl_;
    const std::string label = m.ContainerLabel(container);
    m.estimates.Add({{"container", label}, {"load_status", std::string(load_status)}}).Increment();
    // Counters only grow: a negative volume (noise around an empty container) counts as 0.
    m.volume.Add({{"container", label}}).Increment(std::max(volume_m3, 0.0));
    m.bank_volume.Add({{"container", label}}).Increment(std::max(bank_volume_m3, 0.0));
    if (mass_kg) m.mass.Add({{"container", label}}).Increment(std::max(*mass_kg, 0.0));
}

void Metrics::SetRecordsProbe(std::string store, std::function<RecordFigures()> probe) {
    Impl& m = *impl_;
    m.records_written = &m.MakeCounter("soilvol_records_written_total",
                                       "Estimate records committed by this server", store);
    m.record_batches = &m.MakeCounter("soilvol_record_batches_total",
                                      "Transactions that committed estimate records", store);
    m.record_failures =
        &m.MakeCounter("soilvol_record_failures_total",
                       "Estimate records the store refused (their estimates were refused)", store);
    m.records_pruned = &m.MakeCounter("soilvol_records_pruned_total",
                                      "Estimate records removed by the retention policy", store);
    m.records_queued =
        &m.MakeGauge("soilvol_records_queued", "Estimate records waiting for their commit");
    auto& watches = prometheus::BuildGauge()
                        .Name("soilvol_watches")
                        .Help(
                            "Open watches (gRPC calls and Server-Sent Event streams) by feed; "
                            "--max-watches bounds their sum")
                        .Register(*m.registry);
    m.estimate_watches = &watches.Add({{"feed", "estimates"}});
    m.alert_watches = &watches.Add({{"feed", "alerts"}});
    m.load_watches = &watches.Add({{"feed", "loads"}});
    m.records_probe = std::move(probe);
}

void Metrics::AddCounterProbe(std::string name, std::string help,
                              std::function<std::vector<ProbedValue>()> probe) {
    impl_->counter_probes.push_back({std::move(name), std::move(help), std::move(probe)});
}

std::string Metrics::Serialize() const {
    impl_->ReadRecords();
    std::vector<prometheus::MetricFamily> families = impl_->registry->Collect();
    impl_->AppendProbed(families);
    AppendProcessFamilies(ReadProcessStats(), families);
    return prometheus::TextSerializer().Serialize(families);
}

}  // namespace soilvol::server
