#include "core/volume/load_status.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "absl/strings/str_cat.h"

namespace soilvol::volume {
namespace {

constexpr double kMinDensity = 1.0;
constexpr double kMaxDensity = 30000.0;  // denser than any ore
constexpr double kMinBulking = 0.5;
constexpr double kMaxBulking = 3.0;
constexpr double kInf = std::numeric_limits<double>::infinity();

absl::Status CheckRange(double value, double lo, double hi, const char* field) {
    if (!std::isfinite(value) || value < lo || value > hi) {
        return absl::InvalidArgumentError(
            absl::StrCat(field, ": must be in [", lo, ", ", hi, "] (got ", value, ")"));
    }
    return absl::OkStatus();
}

/// P(lo < X <= hi) for X normal around `mean` with `sigma`.
double BandProbability(double lo, double hi, double mean, double sigma) {
    if (!(sigma > 0.0)) return mean > lo && mean <= hi ? 1.0 : 0.0;
    const auto cdf = [&](double x) {
        if (x == kInf) return 1.0;
        if (x == -kInf) return 0.0;
        return 0.5 * std::erfc(-(x - mean) / (sigma * std::sqrt(2.0)));
    };
    return std::clamp(cdf(hi) - cdf(lo), 0.0, 1.0);
}

}  // namespace

absl::Status CheckLoadRules(const Material& material, const LoadTargets& targets) {
    if (material.density_kg_m3 != 0.0) {
        if (absl::Status s = CheckRange(material.density_kg_m3, kMinDensity, kMaxDensity,
                                        "material.density_kg_m3");
            !s.ok()) {
            return s;
        }
    }
    if (absl::Status s = CheckRange(material.bulking_factor, kMinBulking, kMaxBulking,
                                    "material.bulking_factor");
        !s.ok()) {
        return s;
    }
    if (material.name.size() > 128) {
        return absl::InvalidArgumentError("material.name: at most 128 bytes");
    }
    const char* target_field = targets.quantity == LoadTargets::Quantity::kPayload
                                   ? "load_targets.payload_kg"
                                   : "load_targets.volume_m3";
    switch (targets.quantity) {
        case LoadTargets::Quantity::kNone:
            break;
        case LoadTargets::Quantity::kPayload:
            if (material.density_kg_m3 == 0.0) {
                return absl::InvalidArgumentError(
                    "load_targets.payload_kg: needs material.density_kg_m3 to turn volume into "
                    "mass");
            }
            [[fallthrough]];
        case LoadTargets::Quantity::kVolume:
            if (!std::isfinite(targets.target) || targets.target <= 0.0) {
                return absl::InvalidArgumentError(
                    absl::StrCat(target_field, ": must be > 0 (got ", targets.target, ")"));
            }
            break;
    }
    for (const auto& [value, field] :
         {std::pair<double, const char*>{targets.under_tolerance, "load_targets.under_tolerance"},
          {targets.over_tolerance, "load_targets.over_tolerance"}}) {
        if (absl::Status s = CheckRange(value, 0.0, 1.0, field); !s.ok()) return s;
    }
    for (const auto& [value, field] :
         {std::pair<double, const char*>{targets.carryback_m3, "load_targets.carryback_m3"},
          {targets.empty_m3, "load_targets.empty_m3"}}) {
        if (absl::Status s = CheckRange(value, 0.0, 1e6, field); !s.ok()) return s;
    }
    return absl::OkStatus();
}

LoadAssessment AssessLoad(double volume_m3, double sigma_m3, const Material& material,
                          const LoadTargets& targets, std::optional<double> density_override) {
    LoadAssessment out;
    const double sigma = std::max(0.0, sigma_m3);
    const double density = density_override.value_or(material.density_kg_m3);
    if (density > 0.0) {
        out.mass_kg = volume_m3 * density;
        out.mass_sigma_kg = sigma * density;
    }
    if (material.bulking_factor > 0.0) out.bank_volume_m3 = volume_m3 / material.bulking_factor;

    // Every band on the volume axis, so that one probability rule serves them all.
    const double empty = std::max(targets.empty_m3, 2.0 * sigma);
    const double carryback = std::max(empty, targets.carryback_m3);
    out.empty_threshold_m3 = empty;
    double target_m3 = 0.0;
    switch (targets.quantity) {
        case LoadTargets::Quantity::kNone:
            break;
        case LoadTargets::Quantity::kVolume:
            target_m3 = targets.target;
            break;
        case LoadTargets::Quantity::kPayload:
            if (density > 0.0) target_m3 = targets.target / density;
            break;
    }
    struct Band {
        LoadStatus status;
        double lo, hi;
    };
    std::vector<Band> bands = {{LoadStatus::kEmpty, -kInf, empty},
                               {LoadStatus::kCarryback, empty, carryback}};
    if (target_m3 > 0.0) {
        const double lo = std::max(carryback, target_m3 * (1.0 - targets.under_tolerance));
        const double hi = std::max(lo, target_m3 * (1.0 + targets.over_tolerance));
        bands.push_back({LoadStatus::kUnderloaded, carryback, lo});
        bands.push_back({LoadStatus::kLoadedOk, lo, hi});
        bands.push_back({LoadStatus::kOverloaded, hi, kInf});
        out.target_ratio = volume_m3 / target_m3;
    } else {
        bands.push_back({LoadStatus::kLoaded, carryback, kInf});
    }
    for (const Band& band : bands) {
        if (!(volume_m3 > band.lo && volume_m3 <= band.hi)) continue;
        out.status = band.status;
        out.status_probability = BandProbability(band.lo, band.hi, volume_m3, sigma);
        break;
    }
    return out;
}

}  // namespace soilvol::volume
