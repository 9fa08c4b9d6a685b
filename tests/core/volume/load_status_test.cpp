#include "core/volume/load_status.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace soilvol::volume {
namespace {

LoadTargets VolumeTarget(double m3) {
    LoadTargets targets;
    targets.quantity = LoadTargets::Quantity::kVolume;
    targets.target = m3;
    targets.carryback_m3 = 0.5;
    return targets;
}

TEST(LoadStatus, BandsOfAVolumeTarget) {
    const LoadTargets t = VolumeTarget(10.0);  // OK band 9.5 .. 10.5
    const Material m;
    EXPECT_EQ(AssessLoad(0.03, 0.02, m, t).status, LoadStatus::kEmpty);
    EXPECT_EQ(AssessLoad(0.3, 0.02, m, t).status, LoadStatus::kCarryback);
    EXPECT_EQ(AssessLoad(9.4, 0.02, m, t).status, LoadStatus::kUnderloaded);
    EXPECT_EQ(AssessLoad(9.6, 0.02, m, t).status, LoadStatus::kLoadedOk);
    EXPECT_EQ(AssessLoad(10.5, 0.02, m, t).status, LoadStatus::kLoadedOk);
    EXPECT_EQ(AssessLoad(10.6, 0.02, m, t).status, LoadStatus::kOverloaded);
    EXPECT_NEAR(*AssessLoad(9.0, 0.02, m, t).target_ratio, 0.9, 1e-12);
}

TEST(LoadStatus, EmptyWhileTheLoadIsWithinTwoSigmaOfNothing) {
    const LoadTargets t = VolumeTarget(10.0);
    // 0.7 m3 is above the carryback threshold but indistinguishable from 0 at sigma 0.4.
    const LoadAssessment a = AssessLoad(0.7, 0.4, Material{}, t);
    EXPECT_EQ(a.status, LoadStatus::kEmpty);
    EXPECT_DOUBLE_EQ(a.empty_threshold_m3, 0.8);
    // A configured empty threshold above 2 sigma wins.
    LoadTargets wide = t;
    wide.empty_m3 = 0.2;
    EXPECT_EQ(AssessLoad(0.1, 0.01, Material{}, wide).status, LoadStatus::kEmpty);
}

TEST(LoadStatus, WithoutATargetALoadIsLoaded) {
    LoadTargets none;
    none.carryback_m3 = 0.3;
    EXPECT_EQ(AssessLoad(0.0, 0.01, Material{}, none).status, LoadStatus::kEmpty);
    EXPECT_EQ(AssessLoad(0.2, 0.01, Material{}, none).status, LoadStatus::kCarryback);
    EXPECT_EQ(AssessLoad(5.0, 0.01, Material{}, none).status, LoadStatus::kLoaded);
    EXPECT_FALSE(AssessLoad(5.0, 0.01, Material{}, none).target_ratio.has_value());
}

TEST(LoadStatus, PayloadTargetsGoThroughTheLooseDensity) {
    Material soil{"clay", 1600.0, 1.25};
    LoadTargets t;
    t.quantity = LoadTargets::Quantity::kPayload;
    t.target = 16000.0;  // 10 m3 at 1600 kg/m3
    t.under_tolerance = 0.1;
    const LoadAssessment a = AssessLoad(9.2, 0.1, soil, t);
    EXPECT_EQ(a.status, LoadStatus::kLoadedOk);
    EXPECT_NEAR(*a.mass_kg, 9.2 * 1600.0, 1e-9);
    EXPECT_NEAR(*a.mass_sigma_kg, 160.0, 1e-9);
    EXPECT_NEAR(*a.bank_volume_m3, 9.2 / 1.25, 1e-12);
    EXPECT_NEAR(*a.target_ratio, 0.92, 1e-12);
    // A heavier material (the request's density) moves the same volume over the target.
    EXPECT_EQ(AssessLoad(9.2, 0.1, soil, t, 2000.0).status, LoadStatus::kOverloaded);
}

TEST(LoadStatus, ProbabilityIsTheNormalMassOfTheBand) {
    const LoadTargets t = VolumeTarget(10.0);
    // Centred in a band +-0.5 wide with sigma 0.5: P(|Z| < 1) = 0.6827.
    EXPECT_NEAR(AssessLoad(10.0, 0.5, Material{}, t).status_probability, 0.682689, 1e-5);
    // On the OK band's upper edge: half the mass lies above.
    EXPECT_NEAR(AssessLoad(10.5, 0.1, Material{}, t).status_probability, 0.5, 1e-3);
    // Far inside OVERLOADED: certain.
    EXPECT_NEAR(AssessLoad(20.0, 0.1, Material{}, t).status_probability, 1.0, 1e-12);
    EXPECT_DOUBLE_EQ(AssessLoad(10.0, 0.0, Material{}, t).status_probability, 1.0);
    // No density: no mass.
    EXPECT_FALSE(AssessLoad(10.0, 0.1, Material{}, t).mass_kg.has_value());
}

TEST(LoadStatus, RulesNameTheFieldAtFault) {
    const auto message = [](const Material& m, const LoadTargets& t) {
        return std::string(CheckLoadRules(m, t).message());
    };
    EXPECT_TRUE(CheckLoadRules(Material{}, LoadTargets{}).ok());
    EXPECT_TRUE(CheckLoadRules(Material{"gravel", 1700.0, 1.1}, VolumeTarget(3.0)).ok());
    EXPECT_NE(message(Material{"", -5.0, 1.0}, {}).find("material.density_kg_m3"),
              std::string::npos);
    EXPECT_NE(message(Material{"", std::nan(""), 1.0}, {}).find("material.density_kg_m3"),
              std::string::npos);
    EXPECT_NE(message(Material{"", 1000.0, 0.0}, {}).find("material.bulking_factor"),
              std::string::npos);
    LoadTargets payload;
    payload.quantity = LoadTargets::Quantity::kPayload;
    payload.target = 1000.0;
    EXPECT_NE(message(Material{}, payload).find("load_targets.payload_kg: needs material"),
              std::string::npos);
    LoadTargets zero = VolumeTarget(0.0);
    EXPECT_NE(message(Material{}, zero).find("load_targets.volume_m3"), std::string::npos);
    LoadTargets tolerance = VolumeTarget(1.0);
    tolerance.over_tolerance = 1.5;
    EXPECT_NE(message(Material{}, tolerance).find("load_targets.over_tolerance"),
              std::string::npos);
    LoadTargets carryback = VolumeTarget(1.0);
    carryback.carryback_m3 = -1.0;
    EXPECT_NE(message(Material{}, carryback).find("load_targets.carryback_m3"), std::string::npos);
}

}  // namespace
}  // namespace soilvol::volume
