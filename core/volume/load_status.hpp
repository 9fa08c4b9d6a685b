#pragma once

#include <optional>
#include <string>

#include "absl/status/status.h"

namespace soilvol::volume {

/// What a container holds. Mass comes from the loose density, the material as it lies in the
/// container: mass = volume * density. The bulking factor (loose over in-place, "bank", volume;
/// the swell of dug soil) gives the in-place volume the load was dug from: volume / bulking.
struct Material {
    std::string name;
    double density_kg_m3 = 0.0;  ///< loose; 0: unknown (no mass)
    double bulking_factor = 1.0;
};

/// What a load should be, from which each estimate gets its LoadStatus.
struct LoadTargets {
    enum class Quantity { kNone, kVolume, kPayload };
    Quantity quantity = Quantity::kNone;
    double target = 0.0;            ///< m3 (kVolume) or kg (kPayload)
    double under_tolerance = 0.05;  ///< share of the target below it that is still LOADED_OK
    double over_tolerance = 0.05;   ///< share above it
    /// Loads up to this volume (above empty) are carryback: soil left after dumping. 0: none.
    double carryback_m3 = 0.0;
    /// Loads up to max(this, 2 sigma of the estimate) are empty.
    double empty_m3 = 0.0;
};

enum class LoadStatus { kEmpty, kCarryback, kUnderloaded, kLoadedOk, kOverloaded, kLoaded };

/// An estimate judged against its container's material and targets.
struct LoadAssessment {
    LoadStatus status = LoadStatus::kEmpty;
    /// Chance that the true volume lies in the status's band, with the estimate's error taken
    /// as normal with the given sigma (1 for a sigma of 0).
    double status_probability = 1.0;
    double empty_threshold_m3 = 0.0;  ///< the EMPTY band's upper end used
    std::optional<double> mass_kg, mass_sigma_kg;
    std::optional<double> bank_volume_m3;
    std::optional<double> target_ratio;  ///< volume or mass over the target
};

/// InvalidArgument naming the field ("material.density_kg_m3", "load_targets.payload_kg", ...)
/// for a value outside its range (densities 1..30000 kg/m3, bulking 0.5..3, tolerances 0..1,
/// targets and thresholds finite and >= 0, a target > 0) or a payload target without a density.
absl::Status CheckLoadRules(const Material& material, const LoadTargets& targets);

/// The status of a load of `volume_m3` (one sigma `sigma_m3`) under `targets`, by bands of the
/// volume (a payload target and tolerances convert through the density):
///   EMPTY        volume <= e = max(empty_m3, 2 sigma)
///   CARRYBACK    e < volume <= carryback_m3
///   UNDERLOADED  above those and below target * (1 - under_tolerance)
///   LOADED_OK    target * (1 - under_tolerance) ... target * (1 + over_tolerance)
///   OVERLOADED   above
///   LOADED       above EMPTY and CARRYBACK when there is no target.
/// `density_override` (a request's) replaces the material's density.
LoadAssessment AssessLoad(double volume_m3, double sigma_m3, const Material& material,
                          const LoadTargets& targets,
                          std::optional<double> density_override = std::nullopt);

}  // namespace soilvol::volume
