#include "core/volume/load_totals.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>

namespace soilvol::volume {
namespace {

/// The combined 1-sigma of sum_i k_i v_i (see SumPasses).
double CombinedSigma(const std::vector<PassFigures>& passes,
                     const std::function<double(const PassFigures&)>& scale) {
    double independent = 0.0;
    std::map<std::string, double> shared;
    for (const PassFigures& pass : passes) {
        const double k = scale(pass);
        const double sigma = std::max(0.0, pass.sigma_m3);
        const double s = std::clamp(pass.shared_sigma_m3, 0.0, sigma);
        if (pass.registration.empty()) {
            independent += k * k * sigma * sigma;
            continue;
        }
        independent += k * k * (sigma * sigma - s * s);
        shared[pass.registration] += k * s;
    }
    for (const auto& [registration, linear] : shared) independent += linear * linear;
    return std::sqrt(independent);
}

double Bulking(const PassFigures& pass) {
    return pass.bulking_factor > 0.0 ? pass.bulking_factor : 1.0;
}

}  // namespace

LoadTotals SumPasses(const std::vector<PassFigures>& passes) {
    LoadTotals totals;
    totals.passes = static_cast<int>(passes.size());
    if (passes.empty()) return totals;
    bool every_mass = true;
    double mass = 0.0;
    totals.first_time_us = passes.front().time_us;
    totals.last_time_us = passes.front().time_us;
    for (const PassFigures& pass : passes) {
        totals.volume_m3 += pass.volume_m3;
        totals.bank_volume_m3 += pass.volume_m3 / Bulking(pass);
        every_mass = every_mass && pass.density_kg_m3.has_value();
        if (pass.density_kg_m3) mass += pass.volume_m3 * *pass.density_kg_m3;
        totals.first_time_us = std::min(totals.first_time_us, pass.time_us);
        totals.last_time_us = std::max(totals.last_time_us, pass.time_us);
    }
    totals.sigma_m3 = CombinedSigma(passes, [](const PassFigures&) { return 1.0; });
    totals.bank_sigma_m3 =
        CombinedSigma(passes, [](const PassFigures& pass) { return 1.0 / Bulking(pass); });
    if (every_mass) {
        totals.mass_kg = mass;
        totals.mass_sigma_kg = CombinedSigma(
            passes, [](const PassFigures& pass) { return pass.density_kg_m3.value_or(0.0); });
    }
    if (passes.size() >= 2) {
        totals.mean_cycle_s = 1e-6 *
                              static_cast<double>(totals.last_time_us - totals.first_time_us) /
                              static_cast<double>(passes.size() - 1);
    }
    return totals;
}

Reconciliation Reconcile(const LoadTotals& totals, double body_m3, double body_sigma_m3) {
    Reconciliation out;
    out.passes_m3 = totals.volume_m3;
    out.body_m3 = body_m3;
    out.difference_m3 = body_m3 - totals.volume_m3;
    const double body_sigma = std::max(0.0, body_sigma_m3);
    out.combined_sigma_m3 = std::hypot(totals.sigma_m3, body_sigma);
    if (out.combined_sigma_m3 > 0.0) {
        out.difference_sigmas = std::abs(out.difference_m3) / out.combined_sigma_m3;
    } else {
        out.difference_sigmas = out.difference_m3 == 0.0 ? 0.0 : HUGE_VAL;
    }
    out.within_two_sigma = out.difference_sigmas <= 2.0;
    return out;
}

}  // namespace soilvol::volume
