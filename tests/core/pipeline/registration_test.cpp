#include "core/pipeline/registration.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <vector>

#include "core/sim/scene.hpp"
#include "tests/core/common/counting_stop.hpp"

namespace soilvol::pipeline {
namespace {

// An excavator bucket seen from behind its curved back, which hides its own inside from that
// view; turned half way round, the container shows it.
sim::SceneSpec View(double azimuth_offset_deg, uint64_t scan_seed) {
    sim::SceneSpec spec;
    spec.shape = sim::RandomShape(sim::ContainerFamily::kExcavator, 1);
    spec.sensor = sim::ViewpointFor(*spec.shape, 1);
    spec.sensor.range_noise_sigma_m = 0.01;
    spec.sensor.azimuth_deg += azimuth_offset_deg;
    spec.jitter = {3.0, 0.05};
    spec.scan_seed = scan_seed;
    return spec;
}

TEST(RegistrationTest, ASecondViewFillsWhatTheFirstHid) {
    const sim::Scene first = sim::SimulateScene(View(0.0, 1));
    const sim::Scene turned = sim::SimulateScene(View(180.0, 2));
    const double truth = first.struck_capacity_m3;
    const auto one = RegisterContainer(first.opening_corners_scan,
                                       {{first.points, std::nullopt, {}}}, RegistrationConfig{});
    ASSERT_TRUE(one.ok()) << one.status();
    const auto two = RegisterContainer(
        first.opening_corners_scan,
        {{first.points, std::nullopt, {}}, {turned.points, turned.opening_corners_scan, {}}},
        RegistrationConfig{});
    ASSERT_TRUE(two.ok()) << two.status();
    ASSERT_EQ(two->alignments.size(), 1u);
    EXPECT_EQ(two->model.cavity.size(), 2u);
    // The hidden back is a fifth of the opening or more; both views see nearly all of it.
    EXPECT_LT(one->model.observed_share, 0.9);
    EXPECT_GT(two->model.observed_share, 0.95);
    const double err_one = std::abs(one->model.struck_capacity_m3 - truth);
    const double err_two = std::abs(two->model.struck_capacity_m3 - truth);
    EXPECT_LT(err_two, 0.5 * err_one);
    EXPECT_LT(err_two, 0.02 * truth);
}

TEST(RegistrationTest, ALaterScanWithBadCornersIsInvalidArgumentNamingIt) {
    const sim::Scene first = sim::SimulateScene(View(0.0, 1));
    Corners crossed = first.opening_corners_scan;
    std::swap(crossed[1], crossed[2]);
    const auto r = RegisterContainer(
        first.opening_corners_scan, {{first.points, std::nullopt, {}}, {first.points, crossed, {}}},
        RegistrationConfig{});
    ASSERT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(r.status().message().find("empty scan 2"), std::string::npos) << r.status();
}

TEST(RegistrationTest, ALaterScanOfSomethingElseIsRefusedNamingIt) {
    const sim::Scene first = sim::SimulateScene(View(0.0, 1));
    Cloud wall;
    for (double x = -1.0; x <= 1.0; x += 0.02) {
        for (double y = -1.0; y <= 1.0; y += 0.02) wall.emplace_back(x, y, 6.0);
    }
    const auto r = RegisterContainer(first.opening_corners_scan,
                                     {{first.points, std::nullopt, {}}, {wall, std::nullopt, {}}},
                                     RegistrationConfig{});
    ASSERT_EQ(r.status().code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(r.status().message().find("empty scan 2"), std::string::npos) << r.status();
}

TEST(RegistrationTest, NoScanIsInvalidArgument) {
    const Corners corners = {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                             Eigen::Vector3d(1.0, 1.0, 0.0), Eigen::Vector3d::UnitY()};
    const auto r = RegisterContainer(corners, {}, RegistrationConfig{});
    EXPECT_EQ(r.status().code(), absl::StatusCode::kInvalidArgument);
}

// Stops: the two views of ASecondViewFillsWhatTheFirstHid.
class RegistrationStopTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        const sim::Scene first = sim::SimulateScene(View(0.0, 1));
        const sim::Scene turned = sim::SimulateScene(View(180.0, 2));
        corners_ = new Corners(first.opening_corners_scan);
        scans_ = new std::vector<EmptyScan>{{first.points, std::nullopt, {}},
                                            {turned.points, turned.opening_corners_scan, {}}};
    }
    static void TearDownTestSuite() {
        delete corners_;
        delete scans_;
    }
    static inline Corners* corners_ = nullptr;
    static inline std::vector<EmptyScan>* scans_ = nullptr;
};

TEST_F(RegistrationStopTest, NeverStoppingTokenChangesNothing) {
    const auto plain = RegisterContainer(*corners_, *scans_, RegistrationConfig{});
    const test::CountingStop never(0);
    const auto watched = RegisterContainer(*corners_, *scans_, RegistrationConfig{}, never.token());
    ASSERT_TRUE(plain.ok() && watched.ok());
    // ICP's threads add their sums in any order: equal to rounding.
    EXPECT_NEAR(watched->model.struck_capacity_m3, plain->model.struck_capacity_m3, 1e-9);
    EXPECT_EQ(watched->model.cavity.size(), 2u);
}

// A stop at the first look after the first scan's model ends the call before the second scan is
// looked at, and names it.
TEST_F(RegistrationStopTest, CancelBetweenScansNamesTheNextScan) {
    const test::CountingStop first_only(0);
    ASSERT_TRUE(model::BuildContainerModel((*scans_)[0].points, *corners_, model::ModelConfig{},
                                           first_only.token())
                    .ok());
    const test::CountingStop cancel(first_only.looks() + 1);
    const auto r = RegisterContainer(*corners_, *scans_, RegistrationConfig{}, cancel.token());
    EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled);
    EXPECT_EQ(r.status().message(), "cancelled during preprocessing (empty scan 2 of 2)");
}

TEST_F(RegistrationStopTest, ExpiredDeadlineOrCancelAtAnyLookEndsTheCall) {
    const StopToken expired(StopToken::Clock::now() - std::chrono::seconds(1));
    EXPECT_EQ(RegisterContainer(*corners_, *scans_, RegistrationConfig{}, expired).status().code(),
              absl::StatusCode::kDeadlineExceeded);
    const test::CountingStop never(0);
    ASSERT_TRUE(RegisterContainer(*corners_, *scans_, RegistrationConfig{}, never.token()).ok());
    const long last = never.looks() - 2;  // ICP may take an iteration less another time
    for (const long look : {1L, 3L, last / 8, last / 4, last / 2, 3 * last / 4, last - 1, last}) {
        const test::CountingStop cancel(look);
        const auto r = RegisterContainer(*corners_, *scans_, RegistrationConfig{}, cancel.token());
        EXPECT_EQ(r.status().code(), absl::StatusCode::kCancelled)
            << "look " << look << " of " << never.looks() << ": " << r.status();
    }
}

}  // namespace
}  // namespace soilvol::pipeline
