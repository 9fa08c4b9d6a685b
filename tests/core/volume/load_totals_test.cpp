#include "core/volume/load_totals.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace soilvol::volume {
namespace {

PassFigures Pass(double volume, double sigma, double shared, const std::string& registration,
                 std::int64_t time_s) {
    PassFigures pass;
    pass.volume_m3 = volume;
    pass.sigma_m3 = sigma;
    pass.shared_sigma_m3 = shared;
    pass.registration = registration;
    pass.time_us = time_s * 1'000'000;
    return pass;
}

TEST(LoadTotals, NoPassesIsAnEmptyLoad) {
    const LoadTotals totals = SumPasses({});
    EXPECT_EQ(totals.passes, 0);
    EXPECT_EQ(totals.volume_m3, 0.0);
    EXPECT_FALSE(totals.mean_cycle_s.has_value());
}

TEST(LoadTotals, IndependentErrorsAddInQuadratureSharedOnesLinearly) {
    // Four passes of one bucket: 0.03 random each, 0.04 shared (its registration's capacity).
    std::vector<PassFigures> passes;
    for (int i = 0; i < 4; ++i) passes.push_back(Pass(2.0, 0.05, 0.04, "reg-a", 30 * i));
    const LoadTotals one_bucket = SumPasses(passes);
    EXPECT_DOUBLE_EQ(one_bucket.volume_m3, 8.0);
    // sqrt(4 * 0.03^2 + (4 * 0.04)^2)
    EXPECT_NEAR(one_bucket.sigma_m3, std::sqrt(4 * 0.0009 + 0.0256), 1e-12);
    ASSERT_TRUE(one_bucket.mean_cycle_s.has_value());
    EXPECT_NEAR(*one_bucket.mean_cycle_s, 30.0, 1e-9);
    // The same passes from four registrations: every term independent.
    for (int i = 0; i < 4; ++i) passes[i].registration = "reg-" + std::to_string(i);
    EXPECT_NEAR(SumPasses(passes).sigma_m3, std::sqrt(4 * 0.0025), 1e-12);
}

TEST(LoadTotals, CombinedSigmaMatchesSimulatedLoads) {
    // Ground truth by simulation: each registration draws one capacity error, each pass its
    // own; the spread of the summed error must be the combined sigma.
    std::vector<PassFigures> passes = {
        Pass(1.9, 0.06, 0.05, "a", 0), Pass(2.1, 0.05, 0.05, "a", 40),
        Pass(2.0, 0.08, 0.02, "b", 75), Pass(1.7, 0.04, 0.0, "", 110),
        Pass(2.2, 0.07, 0.05, "a", 150)};
    const LoadTotals totals = SumPasses(passes);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> unit(0.0, 1.0);
    const int trials = 200000;
    double sum_sq = 0.0;
    for (int t = 0; t < trials; ++t) {
        const double shared_a = unit(rng), shared_b = unit(rng);
        double error = 0.0;
        for (const PassFigures& p : passes) {
            const double shared = p.registration == "a"   ? shared_a
                                  : p.registration == "b" ? shared_b
                                                          : 0.0;
            const double s = p.registration.empty() ? 0.0 : p.shared_sigma_m3;
            error += s * shared + std::sqrt(p.sigma_m3 * p.sigma_m3 - s * s) * unit(rng);
        }
        sum_sq += error * error;
    }
    const double simulated = std::sqrt(sum_sq / trials);
    // The standard error of a sample standard deviation is sigma / sqrt(2n): 0.16% here.
    EXPECT_NEAR(totals.sigma_m3, simulated, 5.0 * simulated / std::sqrt(2.0 * trials));
}

TEST(LoadTotals, MassAndBankVolumeScaleEachPass) {
    PassFigures a = Pass(2.0, 0.1, 0.0, "", 0), b = Pass(1.0, 0.1, 0.0, "", 60);
    a.density_kg_m3 = 1500.0;
    b.density_kg_m3 = 1800.0;
    a.bulking_factor = 1.25;
    b.bulking_factor = 1.0;
    const LoadTotals totals = SumPasses({a, b});
    ASSERT_TRUE(totals.mass_kg.has_value());
    EXPECT_DOUBLE_EQ(*totals.mass_kg, 4800.0);
    EXPECT_NEAR(*totals.mass_sigma_kg, std::hypot(150.0, 180.0), 1e-9);
    EXPECT_DOUBLE_EQ(totals.bank_volume_m3, 2.6);
    EXPECT_NEAR(totals.bank_sigma_m3, std::hypot(0.08, 0.1), 1e-12);
    // One pass without a density: the load has no mass.
    b.density_kg_m3.reset();
    EXPECT_FALSE(SumPasses({a, b}).mass_kg.has_value());
}

TEST(LoadTotals, SharedPartIsClampedToTheWholeSigma) {
    const LoadTotals totals =
        SumPasses({Pass(1.0, 0.02, 0.5, "a", 0), Pass(1.0, 0.02, 0.5, "a", 1)});
    EXPECT_NEAR(totals.sigma_m3, 0.04, 1e-12);
}

TEST(Reconciliation, DifferenceAgainstTheCombinedSigma) {
    const LoadTotals totals =
        SumPasses({Pass(3.0, 0.03, 0.0, "", 0), Pass(3.0, 0.04, 0.0, "", 50)});
    const Reconciliation r = Reconcile(totals, 6.09, 0.0);  // sigma of the passes 0.05
    EXPECT_NEAR(r.difference_m3, 0.09, 1e-12);
    EXPECT_NEAR(r.combined_sigma_m3, 0.05, 1e-12);
    EXPECT_NEAR(r.difference_sigmas, 1.8, 1e-9);
    EXPECT_TRUE(r.within_two_sigma);
    const Reconciliation off = Reconcile(totals, 5.7, 0.12);  // combined 0.13, 0.3 off
    EXPECT_NEAR(off.combined_sigma_m3, 0.13, 1e-12);
    EXPECT_FALSE(off.within_two_sigma);
}

TEST(Reconciliation, NoSigmaAtAllIsWithinOnlyWhenEqual) {
    const LoadTotals totals = SumPasses({Pass(1.0, 0.0, 0.0, "", 0)});
    EXPECT_TRUE(Reconcile(totals, 1.0, 0.0).within_two_sigma);
    EXPECT_FALSE(Reconcile(totals, 1.01, 0.0).within_two_sigma);
}

}  // namespace
}  // namespace soilvol::volume
