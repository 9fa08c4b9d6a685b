#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace soilvol::volume {

/// One bucket pass of a truck load: its estimate's figures.
struct PassFigures {
    double volume_m3 = 0.0;  ///< loose
    double sigma_m3 = 0.0;   ///< the estimate's whole 1-sigma
    /// The part of sigma_m3 every estimate against the same registration carries alike (its
    /// struck capacity's 1-sigma - one empty surface, one error - and what the scan did not
    /// see, the same hidden strip each pass): passes sharing a registration add it linearly,
    /// the rest adds in quadrature. Clamped to sigma_m3.
    double shared_sigma_m3 = 0.0;
    std::string registration;     ///< which passes share shared_sigma_m3 ("" shares with no one)
    double bulking_factor = 1.0;  ///< bank volume = volume / bulking
    std::optional<double> density_kg_m3;  ///< loose; none: the pass has no mass
    std::int64_t time_us = 0;
};

/// A load's running total over its passes.
struct LoadTotals {
    int passes = 0;
    double volume_m3 = 0.0, sigma_m3 = 0.0;
    double bank_volume_m3 = 0.0, bank_sigma_m3 = 0.0;
    /// Set when every pass has a mass.
    std::optional<double> mass_kg, mass_sigma_kg;
    std::int64_t first_time_us = 0, last_time_us = 0;
    /// Mean time between consecutive passes; none below two passes.
    std::optional<double> mean_cycle_s;
};

/// The sums of `passes` (any order) with their combined 1-sigma: for each quantity q = k * v
/// (k = 1 for volume, 1 / bulking for bank volume, density for mass),
///   var(q) = sum_i k_i^2 (sigma_i^2 - s_i^2) + sum_r (sum_{i in r} k_i s_i)^2
/// over registrations r, s_i the shared part of pass i.
LoadTotals SumPasses(const std::vector<PassFigures>& passes);

/// A truck body's scan against the passes that filled it.
struct Reconciliation {
    double passes_m3 = 0.0, body_m3 = 0.0;
    double difference_m3 = 0.0;      ///< body - passes
    double combined_sigma_m3 = 0.0;  ///< sqrt(sigma_passes^2 + sigma_body^2)
    double difference_sigmas = 0.0;  ///< |difference| / combined sigma (0 when both are 0)
    bool within_two_sigma = false;
};

/// `totals` (the passes) against a body scan of `body_m3` with 1-sigma `body_sigma_m3`. The
/// two are independent measurements (other sensors, other containers).
Reconciliation Reconcile(const LoadTotals& totals, double body_m3, double body_sigma_m3);

}  // namespace soilvol::volume
