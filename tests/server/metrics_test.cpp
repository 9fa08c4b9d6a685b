#include "server/dispatch/metrics.hpp"

#include <gtest/gtest.h>

#include <string>

namespace soilvol::server {
namespace {

// The sample line of `name{labels}` in `text`, "" when there is none.
std::string Sample(const std::string& text, const std::string& name_and_labels) {
    const std::size_t at = text.find("\n" + name_and_labels + " ");
    if (at == std::string::npos) return "";
    return text.substr(at + 1, text.find('\n', at + 1) - at - 1);
}

double Value(const std::string& text, const std::string& name_and_labels) {
    const std::string line = Sample(text, name_and_labels);
    return line.empty() ? -1.0 : std::stod(line.substr(line.rfind(' ') + 1));
}

TEST(MetricsTest, EstimatesAreCountedPerContainerWithABoundedLabelSet) {
    Metrics metrics(2);
    metrics.RecordEstimate("bucket-7", "loaded_ok", 1.5, 1.2, 2700.0);
    metrics.RecordEstimate("bucket-7", "overloaded", 2.5, 2.0, 4500.0);
    metrics.RecordEstimate("truck-1", "loaded", 10.0, 8.0, std::nullopt);
    metrics.RecordEstimate("bin-3", "empty", -0.01, -0.008, 0.0);  // beyond 2: "_other"
    metrics.RecordEstimate("bin-4", "empty", 0.5, 0.4, std::nullopt);
    const std::string text = metrics.Serialize();
    EXPECT_EQ(
        Value(text, R"(soilvol_estimates_total{container="bucket-7",load_status="loaded_ok"})"),
        1.0);
    EXPECT_EQ(Value(text, R"(soilvol_estimated_volume_cubic_meters_total{container="bucket-7"})"),
              4.0);
    EXPECT_EQ(
        Value(text, R"(soilvol_estimated_bank_volume_cubic_meters_total{container="bucket-7"})"),
        3.2);
    EXPECT_EQ(Value(text, R"(soilvol_estimated_mass_kilograms_total{container="bucket-7"})"),
              7200.0);
    EXPECT_EQ(Value(text, R"(soilvol_estimated_volume_cubic_meters_total{container="truck-1"})"),
              10.0);
    EXPECT_EQ(Sample(text, R"(soilvol_estimated_mass_kilograms_total{container="truck-1"})"), "");
    // Counters never fall: the small negative volume of an empty container counts as 0.
    EXPECT_EQ(Value(text, R"(soilvol_estimates_total{container="_other",load_status="empty"})"),
              2.0);
    EXPECT_EQ(Value(text, R"(soilvol_estimated_volume_cubic_meters_total{container="_other"})"),
              0.5);
    EXPECT_EQ(text.find("bin-3"), std::string::npos);
}

TEST(MetricsTest, AProbedCounterFamilyIsReadAtEachScrape) {
    Metrics metrics;
    double delivered = 3.0;
    metrics.AddCounterProbe("soilvol_webhook_deliveries_total", "Attempts", [&delivered] {
        return std::vector<Metrics::ProbedValue>{
            {{{"webhook", "fleet"}, {"outcome", "delivered"}}, delivered},
            {{{"webhook", "fleet"}, {"outcome", "failed"}}, 1.0}};
    });
    std::string text = metrics.Serialize();
    EXPECT_NE(text.find("# TYPE soilvol_webhook_deliveries_total counter"), std::string::npos);
    EXPECT_EQ(
        Value(text, R"(soilvol_webhook_deliveries_total{webhook="fleet",outcome="delivered"})"),
        3.0);
    delivered = 5.0;
    text = metrics.Serialize();
    EXPECT_EQ(
        Value(text, R"(soilvol_webhook_deliveries_total{webhook="fleet",outcome="delivered"})"),
        5.0);
    EXPECT_EQ(Value(text, R"(soilvol_webhook_deliveries_total{webhook="fleet",outcome="failed"})"),
              1.0);
}

TEST(MetricsTest, TheScrapeHoldsTheProcessFigures) {
    const std::string text = Metrics().Serialize();
    for (const char* name : {"process_cpu_seconds_total", "process_resident_memory_bytes",
                             "process_virtual_memory_bytes", "process_start_time_seconds",
                             "process_open_fds", "process_max_fds"}) {
        EXPECT_NE(text.find(std::string("# TYPE ") + name), std::string::npos) << name;
        EXPECT_GE(Value(text, name), 0.0) << name;  // -1: no sample
    }
    EXPECT_GT(Value(text, "process_resident_memory_bytes"), 1 << 20);
    EXPECT_GT(Value(text, "process_start_time_seconds"), 1.7e9);  // after 2023
    EXPECT_NE(text.find("# TYPE process_cpu_seconds_total counter"), std::string::npos);
}

}  // namespace
}  // namespace soilvol::server
