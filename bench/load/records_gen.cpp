// soilvol-records-gen: a generated records database for the production benchmark
// (bench/load/production.sh): N estimate records over D days, through the same RecordStore the
// server writes with (so the rollup is what the server would have kept), in batches.
// Containers take turns; every container's passes fill loads of 4-6 passes of haul units
// taking turns, as an excavator loads trucks; materials by container, statuses drawn.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "server/records/record_store.hpp"

namespace {

struct Options {
    std::string url;
    std::int64_t records = 1'000'000;
    int days = 30;
    int containers = 20;
    int haul_units = 60;
    int batch = 2000;
    std::int64_t end_us = 0;  ///< 0: now
};

/// One container's current load: its id and the passes it still takes.
struct OpenLoad {
    std::string id;
    std::string truck;
    int passes_left = 0;
};

/// Appends `batch` (every record must be kept) and empties it.
bool Flush(soilvol::server::RecordStore& store,
           std::vector<soilvol::server::EstimateRecord>& batch) {
    if (absl::Status s = store.Append(batch); !s.ok()) {
        std::cerr << s << "\n";
        return false;
    }
    for (const soilvol::server::EstimateRecord& kept : batch) {
        if (!kept.rejected.ok()) {
            std::cerr << "a record was refused: " << kept.rejected << "\n";
            return false;
        }
    }
    batch.clear();
    return true;
}

int Generate(const Options& o) {
    using namespace soilvol::server;
    absl::StatusOr<std::unique_ptr<RecordStore>> store = OpenRecordStore(o.url, "/nonexistent");
    if (!store.ok()) {
        std::cerr << store.status() << "\n";
        return 1;
    }
    const std::int64_t end = o.end_us != 0
                                 ? o.end_us
                                 : std::chrono::duration_cast<std::chrono::microseconds>(
                                       std::chrono::system_clock::now().time_since_epoch())
                                       .count();
    const std::int64_t span = static_cast<std::int64_t>(o.days) * 86400LL * 1'000'000;
    const std::int64_t step = span / o.records;
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> volume(0.6, 1.0);
    std::uniform_int_distribution<int> status(3, 5), passes(4, 6);
    std::vector<OpenLoad> loads(static_cast<std::size_t>(o.containers));
    std::int64_t next_load = 0;
    const auto start_clock = std::chrono::steady_clock::now();
    std::vector<EstimateRecord> batch;
    std::set<std::string> batch_trucks;  ///< haul units whose loads the batch's passes fill
    for (std::int64_t i = 0; i < o.records; ++i) {
        const int c = static_cast<int>(i % o.containers);
        EstimateRecord r;
        r.container_id = absl::StrFormat("excavator-%02d", c);
        r.create_time_us = end - span + i * step;
        r.request_id = absl::StrFormat("gen-%d", i);
        r.registration_id = "gen";
        r.payload = std::string(64, 'p');
        OpenLoad& load = loads[static_cast<std::size_t>(c)];
        const std::string truck = absl::StrFormat("truck-%02d", next_load % o.haul_units);
        if (load.passes_left == 0 && batch_trucks.count(truck) > 0) {
            // The truck's new load would close the one the batch's passes fill: commit first.
            if (!Flush(**store, batch)) return 1;
            batch_trucks.clear();
        }
        if (load.passes_left == 0) {
            LoadRecord created;
            created.load_id = absl::StrFormat("gen-load-%d", next_load);
            created.haul_unit_id = truck;
            ++next_load;
            created.create_time_us = created.update_time_us = created.last_activity_us =
                r.create_time_us;
            created.payload = "";
            if (absl::Status s = store.value()->CreateLoad(created, 0); !s.ok()) {
                std::cerr << s << "\n";
                return 1;
            }
            load = {created.load_id, truck, passes(rng)};
        }
        batch_trucks.insert(load.truck);
        --load.passes_left;
        r.load = LoadLink{load.id, LoadLink::kPass, 0};
        r.measures.volume_m3 = volume(rng);
        r.measures.bank_volume_m3 = r.measures.volume_m3 / 1.25;
        r.measures.mass_kg = r.measures.volume_m3 * 1600.0;
        r.measures.fill_ratio = r.measures.volume_m3 / 0.8;
        r.measures.load_status = status(rng);
        r.measures.material = c % 3 == 0 ? "sand" : "clay";
        batch.push_back(std::move(r));
        if (static_cast<int>(batch.size()) == o.batch || i + 1 == o.records) {
            if (!Flush(**store, batch)) return 1;
            batch_trucks.clear();
        }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_clock).count();
    std::cout << absl::StrFormat(
        "records=%d loads=%d days=%d containers=%d haul_units=%d seconds=%.1f end_us=%d\n",
        o.records, next_load, o.days, o.containers, o.haul_units, seconds, end);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    Options o;
    CLI::App app{"soilvol-records-gen: a generated records database (production benchmark)"};
    app.add_option("--url", o.url, "records URL: sqlite:<path> or postgresql://...")->required();
    app.add_option("--records", o.records, "estimate records")->capture_default_str();
    app.add_option("--days", o.days, "over this many days, ending now")->capture_default_str();
    app.add_option("--containers", o.containers, "excavators taking turns")->capture_default_str();
    app.add_option("--haul-units", o.haul_units, "trucks taking turns")->capture_default_str();
    app.add_option("--batch", o.batch, "records per transaction")->capture_default_str();
    app.add_option("--end-us", o.end_us, "the last record's time (0: now)");
    CLI11_PARSE(app, argc, argv);
    return Generate(o);
}
