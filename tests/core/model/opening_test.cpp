#include "core/model/opening.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace soilvol::model {
namespace {

// A 2 x 0.5 m opening seen from a sensor 2 m above it, with a floor 0.5 m below.
Corners FlatCorners() {
    return {Eigen::Vector3d(-1.0, -0.25, 2.0), Eigen::Vector3d(1.0, -0.25, 2.0),
            Eigen::Vector3d(1.0, 0.25, 2.0), Eigen::Vector3d(-1.0, 0.25, 2.0)};
}

Cloud FloorBelow(double z) {
    Cloud floor;
    for (double x = -0.9; x <= 0.9; x += 0.05) {
        for (double y = -0.2; y <= 0.2; y += 0.05) floor.emplace_back(x, y, z);
    }
    return floor;
}

void ExpectInvalid(const Corners& corners, const std::string& needle) {
    const auto opening = MakeOpening(corners, FloorBelow(2.5), OpeningConfig{});
    ASSERT_FALSE(opening.ok());
    EXPECT_EQ(opening.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(opening.status().message().find(needle), std::string::npos) << opening.status();
}

TEST(OpeningTest, NormalPointsAwayFromTheFloor) {
    // Sensor frame: z is depth, so the floor (farther) is at larger z; "out" is towards -z.
    const auto opening = MakeOpening(FlatCorners(), FloorBelow(2.5), OpeningConfig{});
    ASSERT_TRUE(opening.ok()) << opening.status();
    EXPECT_NEAR(opening->T_scan_container.linear().col(2).z(), -1.0, 1e-12);
    EXPECT_NEAR(opening->area_m2, 1.0, 1e-12);
    EXPECT_TRUE(opening->T_scan_container.translation().isApprox(Eigen::Vector3d(0, 0, 2), 1e-12));
    const Cloud floor = ToContainerFrame(FloorBelow(2.5), opening->T_scan_container);
    for (const auto& p : floor) EXPECT_NEAR(p.z(), -0.5f, 1e-6f);
}

TEST(OpeningTest, ClockwiseOrderGivesTheSameInside) {
    Corners reversed = FlatCorners();
    std::swap(reversed[1], reversed[3]);
    const auto opening = MakeOpening(reversed, FloorBelow(2.5), OpeningConfig{});
    ASSERT_TRUE(opening.ok()) << opening.status();
    EXPECT_NEAR(opening->T_scan_container.linear().col(2).z(), -1.0, 1e-12);
}

TEST(OpeningTest, CoincidentCornersAreRejected) {
    Corners c = FlatCorners();
    c[2] = c[1];
    ExpectInvalid(c, "coincident");
}

TEST(OpeningTest, CollinearCornersAreRejected) {
    Corners c = {Eigen::Vector3d(0, 0, 2), Eigen::Vector3d(1, 0, 2), Eigen::Vector3d(2, 0, 2),
                 Eigen::Vector3d(3, 0, 2)};
    ExpectInvalid(c, "collinear");
    Corners three = FlatCorners();
    three[2] = 0.5 * (three[1] + three[3]);  // corner 2 on the line 1-3: a triangle
    ExpectInvalid(three, "collinear");
}

TEST(OpeningTest, SelfIntersectingOrderIsRejected) {
    Corners c = FlatCorners();
    std::swap(c[2], c[3]);
    ExpectInvalid(c, "edges cross");
}

TEST(OpeningTest, FarFromPlanarIsRejected) {
    Corners c = FlatCorners();
    c[2].z() += 0.4;
    ExpectInvalid(c, "far from planar");
}

TEST(OpeningTest, NonFiniteCornerIsRejected) {
    Corners c = FlatCorners();
    c[0].x() = std::numeric_limits<double>::quiet_NaN();
    ExpectInvalid(c, "not finite");
}

// The attack of issue 12: a 3 km opening in a 47 KB request. Openings beyond the containers
// served are refused by their corners, before any grid or raster is sized from them.
TEST(OpeningTest, OpeningsBeyondTheServedContainersAreRejectedByTheirCorners) {
    for (const double side : {31.0, 3000.0, 1e30}) {
        Corners corners = FlatCorners();
        corners[1].x() = corners[0].x() + side;
        corners[2].x() = corners[0].x() + side;
        ExpectInvalid(corners, "opening.corners");
    }
    // 25 x 20 m: each side is allowed, the area (500 m^2) is not.
    const Corners wide = {Eigen::Vector3d(-12.5, -10.0, 2.0), Eigen::Vector3d(12.5, -10.0, 2.0),
                          Eigen::Vector3d(12.5, 10.0, 2.0), Eigen::Vector3d(-12.5, 10.0, 2.0)};
    ExpectInvalid(wide, "m^2");
    // A 25 x 4 m rail wagon is served.
    const Corners wagon = {Eigen::Vector3d(-12.5, -2.0, 2.0), Eigen::Vector3d(12.5, -2.0, 2.0),
                           Eigen::Vector3d(12.5, 2.0, 2.0), Eigen::Vector3d(-12.5, 2.0, 2.0)};
    EXPECT_TRUE(MakeOpening(wagon, FloorBelow(2.5), OpeningConfig{}).ok());
}

TEST(OpeningTest, NoPointOverTheOpeningIsRejected) {
    Cloud elsewhere = FloorBelow(2.5);
    for (auto& p : elsewhere) p.x() += 5.0f;
    const auto opening = MakeOpening(FlatCorners(), elsewhere, OpeningConfig{});
    ASSERT_FALSE(opening.ok());
    EXPECT_NE(opening.status().message().find("over the opening"), std::string::npos);
}

}  // namespace
}  // namespace soilvol::model

namespace soilvol::model {
namespace {

// A 2 x 1 m opening, a sensor 2 m in front (-y) and 2 m above it.
const Polygon2d kOpening({{-1.0, -0.5}, {1.0, -0.5}, {1.0, 0.5}, {-1.0, 0.5}});
const Eigen::Vector3d kFront(0.0, -2.5, 2.0);

TEST(EntersThroughOpeningTest, ReturnsOnTheFloorAndFarWallCameThroughTheOpening) {
    EXPECT_TRUE(EntersThroughOpening(kFront, Eigen::Vector3f(0.0f, 0.3f, -0.6f), kOpening));
    EXPECT_TRUE(EntersThroughOpening(kFront, Eigen::Vector3f(0.5f, 0.5f, -0.2f), kOpening));
}

TEST(EntersThroughOpeningTest, TheOutsideOfAWallLeaningOverTheOpeningCameThroughTheWall) {
    // The near wall leans in by 10 cm over its 0.8 m: its outside at 0.6 m depth lies 5 cm
    // inside the edge, and the ray to it crosses the opening plane 0.4 m in front of the edge.
    const Eigen::Vector3f outside(0.0f, -0.45f, -0.6f);
    EXPECT_FALSE(EntersThroughOpening(kFront, outside, kOpening));
    const Cloud kept =
        ThroughOpening({outside, Eigen::Vector3f(0.0f, 0.3f, -0.6f)}, kFront, kOpening);
    ASSERT_EQ(kept.size(), 1u);
    EXPECT_FLOAT_EQ(kept[0].y(), 0.3f);
}

TEST(EntersThroughOpeningTest, ReturnsAboveThePlaneAndSensorsBelowItPass) {
    EXPECT_TRUE(EntersThroughOpening(kFront, Eigen::Vector3f(0.0f, -0.45f, 0.2f), kOpening));
    EXPECT_TRUE(EntersThroughOpening(Eigen::Vector3d(0.0, -2.5, -0.5),
                                     Eigen::Vector3f(0.0f, -0.45f, -0.6f), kOpening));
}

}  // namespace
}  // namespace soilvol::model
