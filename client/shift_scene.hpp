#pragma once

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "client/demo_scene.hpp"

namespace soilvol::client {

/// A simulated shift at a loading point: an excavator bucket (client::MakeDemoSetup's
/// excavator, the paper's ToF sensor) fills haul trucks of one body type (the truck bed, its
/// sensor at the exit) pass after pass.
struct ShiftPlan {
    struct Truck {
        std::vector<double> pass_fills;  ///< each pass's fill as a share of the bucket's depth
    };
    std::vector<Truck> trucks;
    DemoSetup bucket, body;
};

/// `trucks` trucks of `min_passes`..`max_passes` passes each, fills drawn uniformly in
/// 0.85..1.15 of the bucket's depth (struck to heaped), seeded.
ShiftPlan MakeShiftPlan(int trucks, int min_passes, int max_passes, std::uint64_t seed);

/// Pass `pass` (from 0) of truck `truck`: its own soil surface and pose jitter; `attempt` > 0
/// scans the same soil again (another jitter and noise), as after a refused scan.
absl::StatusOr<DemoScan> SimulatePass(const ShiftPlan& plan, int truck, int pass, int attempt);

/// The body of truck `truck` holding `volume_m3` of soil (the passes' true sum: nothing spilled,
/// the soil as loose as in the bucket), its surface drawn for this truck. InvalidArgument when
/// the body cannot hold it (heaped 1:1).
absl::StatusOr<DemoScan> SimulateBody(const ShiftPlan& plan, int truck, double volume_m3,
                                      int attempt);

}  // namespace soilvol::client
