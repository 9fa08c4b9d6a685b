#pragma once

#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// The demo prints volumes in litres.
inline constexpr double kLitre = 1000.0;  // litres per cubic metre

/// One demo measurement: the estimate of a simulated fill against its exact truth.
struct DemoRow {
    double fill_share = 0.0;  ///< of the container depth
    double true_volume_m3 = 0.0;
    double struck_capacity_m3 = 0.0;                     ///< true, for the relative error
    std::optional<v1::EstimateVolumeResponse> estimate;  ///< empty when the RPC failed
    std::string error;                                   ///< "CODE: message" when it failed
    double round_trip_ms = 0.0;
};

/// The rows as an aligned table with units in the headers, or with `json` as one JSON array
/// of objects (fill, trueL, measuredL, errorL, errorPctStruck, uncertaintyL, serverMs,
/// roundTripMs; error instead of the measured fields for a failed estimate).
void PrintDemoRows(const std::vector<DemoRow>& rows, bool json, std::ostream& out);

}  // namespace soilvol::client
