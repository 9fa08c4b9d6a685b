#include "client/shift_scene.hpp"

#include <random>

#include "absl/strings/str_format.h"
#include "core/sim/scene.hpp"

namespace soilvol::client {
namespace {

/// The setup for one scan of `base`: its own soil surface and jitter, from `seed`.
DemoSetup Reseeded(const DemoSetup& base, std::uint64_t seed) {
    DemoSetup setup = base;
    setup.seed = seed;
    return setup;
}

std::uint64_t PassSeed(const ShiftPlan& plan, int truck, int pass) {
    return plan.bucket.seed * 10007 + static_cast<std::uint64_t>(truck) * 101 +
           static_cast<std::uint64_t>(pass) + 1;
}

}  // namespace

ShiftPlan MakeShiftPlan(int trucks, int min_passes, int max_passes, std::uint64_t seed) {
    ShiftPlan plan;
    plan.bucket = MakeDemoSetup(sim::ContainerKind::kExcavatorBucket, DemoSensor::kCloud, seed);
    plan.body = MakeDemoSetup(sim::ContainerKind::kTruckBed, DemoSensor::kCloud, seed);
    std::mt19937_64 rng(seed);
    std::uniform_int_distribution<int> passes(min_passes, max_passes);
    std::uniform_real_distribution<double> fill(0.85, 1.15);
    for (int t = 0; t < trucks; ++t) {
        ShiftPlan::Truck truck;
        const int n = passes(rng);
        for (int p = 0; p < n; ++p) truck.pass_fills.push_back(fill(rng));
        plan.trucks.push_back(std::move(truck));
    }
    return plan;
}

absl::StatusOr<DemoScan> SimulatePass(const ShiftPlan& plan, int truck, int pass, int attempt) {
    const DemoSetup setup = Reseeded(plan.bucket, PassSeed(plan, truck, pass));
    return SimulateDemoScan(setup, plan.trucks.at(truck).pass_fills.at(pass),
                            1 + static_cast<std::uint64_t>(attempt), "");
}

absl::StatusOr<DemoScan> SimulateBody(const ShiftPlan& plan, int truck, double volume_m3,
                                      int attempt) {
    const DemoSetup setup = Reseeded(plan.body, plan.body.seed * 10007 + 5000 + truck);
    const sim::ContainerGeometry geometry = sim::MakeContainer(setup.kind);
    // The fill height that holds the volume: the soil's volume grows with it (bisection).
    const auto volume_at = [&](double height_m) {
        sim::SoilSpec soil;
        soil.fill_height_m = height_m;
        return sim::TrueSoilVolume(geometry, soil, setup.seed);
    };
    double lo = 0.0, hi = 2.0 * geometry.depth_m;
    if (volume_at(hi) < volume_m3) {
        return absl::InvalidArgumentError(
            absl::StrFormat("a %.2f m^3 load does not fit the truck body", volume_m3));
    }
    for (int i = 0; i < 40 && hi - lo > 1e-5; ++i) {
        const double mid = 0.5 * (lo + hi);
        (volume_at(mid) < volume_m3 ? lo : hi) = mid;
    }
    return SimulateDemoScan(setup, 0.5 * (lo + hi) / geometry.depth_m,
                            1 + static_cast<std::uint64_t>(attempt), "");
}

}  // namespace soilvol::client
