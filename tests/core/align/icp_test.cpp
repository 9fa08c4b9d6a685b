#include "core/align/icp.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/angles.hpp"
#include "tests/core/align/test_object.hpp"
#include "tests/core/common/counting_stop.hpp"

namespace soilvol::align {
namespace {

// The model's alignment set: smoothed, voxel-thinned, with normals (as ContainerModel's).
struct Source {
    Cloud points, normals;
};
Source MakeSource(const Cloud& object) {
    const cloud::LocalSurface s = SmoothedAsModel(object);
    return {s.points, s.normals};
}

Cloud Transformed(const Cloud& c, const Pose& T, double sigma, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, sigma);
    Cloud out;
    for (const auto& p : c) {
        out.push_back((T * p.cast<double>() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)))
                          .cast<float>());
    }
    return out;
}

Pose RandomPose(double max_deg, double max_m, std::mt19937& rng) {
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Pose T = Pose::Identity();
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    T.linear() = Eigen::AngleAxisd(max_deg * kPi / 180.0 * std::abs(u(rng)), axis).matrix();
    T.translation() = max_m * Eigen::Vector3d(u(rng), u(rng), u(rng)) / std::sqrt(3.0);
    return T;
}

TEST(IcpTest, RecoversSmallPoseChangesWithinTheNoise) {
    const Cloud object = Object();
    const Source source = MakeSource(object);
    Pose placed = Pose::Identity();
    placed.translation() = Eigen::Vector3d(0.1, -0.2, 3.0);
    std::mt19937 rng(7);
    for (int trial = 0; trial < 5; ++trial) {
        const Pose truth = placed * RandomPose(5.0, 0.10, rng);
        const Cloud scan = Transformed(object, truth, 0.005, 10 + trial);
        const AlignResult r = Align(source.points, source.normals, scan, placed, AlignConfig{});
        ASSERT_TRUE(r.converged) << trial;
        const Pose error = truth.inverse() * r.T_scan_container;
        EXPECT_LT(error.translation().norm(), 0.005) << trial;
        EXPECT_LT(Eigen::AngleAxisd(error.linear()).angle() * 180.0 / kPi, 0.3) << trial;
        EXPECT_GT(r.fitness, 0.9);
        EXPECT_TRUE(CheckAlignment(r, AlignGate{}).ok()) << CheckAlignment(r, AlignGate{});
    }
}

TEST(IcpTest, CovarianceIsSmallForAShapeThatPinsThePoseAndLargeForAPlane) {
    const Cloud object = Object();
    const Source source = MakeSource(object);
    const AlignResult box =
        Align(source.points, source.normals, Transformed(object, Pose::Identity(), 0.005, 1),
              Pose::Identity(), AlignConfig{});
    const double box_sigma = std::sqrt(box.covariance.bottomRightCorner<3, 3>().trace());
    EXPECT_GT(box_sigma, 0.0);
    EXPECT_LT(box_sigma, 0.002);
    // A plane leaves its in-plane translation and its normal rotation free: the gate refuses.
    Cloud plane;
    for (double x = -1.0; x <= 1.0; x += 0.01) {
        for (double y = -1.0; y <= 1.0; y += 0.01) plane.emplace_back(x, y, 0.0);
    }
    const Source flat = MakeSource(plane);
    const AlignResult r =
        Align(flat.points, flat.normals, Transformed(plane, Pose::Identity(), 0.005, 2),
              Pose::Identity(), AlignConfig{});
    const absl::Status gate = CheckAlignment(r, AlignGate{});
    EXPECT_EQ(gate.code(), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(gate.message().find("pose 1-sigma"), std::string::npos);
}

// The reported 1-sigma must describe how far found poses scatter over noise draws (of the
// empty scan the model came from and of the filled one): with the scan smoothed over 8 cm and one
// alignment point per 3 cm voxel, neighbouring residuals share their returns, and a covariance that
// took them as independent was 4-5 times too narrow.
TEST(IcpTest, ReportedSigmaMatchesTheScatterOfFoundPoses) {
    const Cloud object = Object();
    constexpr int kDraws = 24;
    constexpr double kNoise = 0.02;
    double sum = 0.0, sum_sq = 0.0, reported = 0.0;
    for (int draw = 0; draw < kDraws; ++draw) {
        // The model comes from an empty scan with the same noise as the filled one.
        const Source source = MakeSource(Transformed(object, Pose::Identity(), kNoise, 500 + draw));
        const Cloud scan = Transformed(object, Pose::Identity(), kNoise, 100 + draw);
        const AlignResult r =
            Align(source.points, source.normals, scan, Pose::Identity(), AlignConfig{});
        ASSERT_TRUE(r.converged) << draw;
        const double z = r.T_scan_container.translation().z();
        sum += z;
        sum_sq += z * z;
        reported += std::sqrt(r.covariance(5, 5));
    }
    const double mean = sum / kDraws;
    const double scatter = std::sqrt(std::max(0.0, sum_sq / kDraws - mean * mean));
    reported /= kDraws;
    // The spread of found heights about the truth (bias included) over the mean reported 1-sigma:
    // 24 draws estimate a standard deviation to about 15%; a factor 2 either way is a failure.
    const double spread = std::sqrt(scatter * scatter + mean * mean);
    EXPECT_GT(reported, 0.5 * spread) << "reported " << reported << " spread " << spread;
    EXPECT_LT(reported, 2.0 * spread) << "reported " << reported << " spread " << spread;
}

TEST(IcpTest, ReturnsInTheContentColumnAreNotContainer) {
    const Cloud object = Object();
    // The model: the box without its inside; the scan: the same box holding a slab of soil
    // 20 cm below the rim, which a target smoothed across the opening would blend into it.
    Cloud outside;
    ContentColumn column{Polygon2d({{-0.6, -0.4}, {0.6, -0.4}, {0.6, 0.4}, {-0.6, 0.4}}), 0.05};
    for (const auto& p : object) {
        if (!column.Holds(p.cast<double>())) outside.push_back(p);
    }
    const Source source = MakeSource(outside);
    Cloud scan = object;
    for (double x = -0.58; x <= 0.58; x += 0.01) {
        for (double y = -0.38; y <= 0.38; y += 0.01) scan.emplace_back(x, y, -0.2);
    }
    const AlignResult with =
        Align(source.points, source.normals, scan, Pose::Identity(), AlignConfig{}, &column);
    EXPECT_LT(with.T_scan_container.translation().norm(), 0.003);
    EXPECT_GT(with.fitness, 0.8);
}

// The column's rule, as its documentation states it: over the opening below the top (but the
// margin along the edge), and the walls' band below the opening; its raster index agrees.
TEST(IcpTest, ContentColumnHoldsWhatItsRuleSays) {
    const Polygon2d polygon({{-0.6, -0.4}, {0.6, -0.4}, {0.7, 0.4}, {-0.5, 0.5}});
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> xy(-0.9, 0.9), z(-0.4, 0.2);
    for (const double margin : {0.0, 0.03}) {
        const ContentColumn column{polygon, 0.05, 0.05, margin};
        const ContentColumnIndex index(column);
        int held = 0;
        for (int i = 0; i < 20000; ++i) {
            const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
            const bool inside = polygon.Contains(p.head<2>());
            const double edge = polygon.DistanceToBoundary(p.head<2>());
            const bool wall = p.z() < -0.05 && (inside || edge < 0.05);
            const bool over = inside && p.z() < 0.05 && (margin <= 0.0 || edge > margin);
            ASSERT_EQ(column.Holds(p), wall || over) << p.transpose() << " margin " << margin;
            ASSERT_EQ(index.Holds(p), wall || over) << p.transpose() << " margin " << margin;
            held += wall || over ? 1 : 0;
        }
        EXPECT_GT(held, 2000);
        EXPECT_LT(held, 18000);
    }
}

// The raster index agrees with the polygon everywhere, also on a concave polygon of a truck's
// size (coarser cells) and right along its edges and thresholds.
TEST(IcpTest, ContentColumnIndexAnswersAsThePolygon) {
    const Polygon2d polygon(
        {{0.0, 0.0}, {6.0, 0.0}, {6.0, 2.5}, {3.5, 2.5}, {3.0, 1.2}, {2.5, 2.5}, {0.0, 2.5}});
    const ContentColumn column{polygon, 0.1, 0.07, 0.03};
    const ContentColumnIndex index(column);
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> x(-0.5, 6.5), y(-0.5, 3.0), z(-0.3, 0.2),
        jitter(-0.12, 0.12);
    const auto& v = polygon.Vertices();
    for (int i = 0; i < 40000; ++i) {
        Eigen::Vector3d p(x(rng), y(rng), z(rng));
        if (i % 2 == 0) {
            // Near an edge: a point on it moved by up to 12 cm.
            const std::size_t e = static_cast<std::size_t>(i / 2) % v.size();
            const double t = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
            const Eigen::Vector2d on = v[e] + t * (v[(e + 1) % v.size()] - v[e]);
            p.head<2>() = on + Eigen::Vector2d(jitter(rng), jitter(rng));
        }
        ASSERT_EQ(index.Holds(p), column.Holds(p)) << p.transpose();
    }
}

// The scan of a moved object and where ICP starts: the object's pose before the move.
struct MovedObject {
    Source source;
    Cloud scan;
    Pose truth;
};
MovedObject Moved() {
    const Cloud object = Object();
    std::mt19937 rng(11);
    const Pose truth = RandomPose(5.0, 0.10, rng);
    return {MakeSource(object), Transformed(object, truth, 0.005, 3), truth};
}

TEST(IcpTest, NeverStoppingTokenChangesNothing) {
    const MovedObject moved = Moved();
    const AlignResult plain = Align(moved.source.points, moved.source.normals, moved.scan,
                                    Pose::Identity(), AlignConfig{});
    const test::CountingStop never(0);
    const AlignResult watched = Align(moved.source.points, moved.source.normals, moved.scan,
                                      Pose::Identity(), AlignConfig{}, nullptr, never.token());
    ASSERT_TRUE(plain.converged);
    EXPECT_TRUE(watched.converged);
    EXPECT_EQ(watched.iterations, plain.iterations);
    // Threads add their partial sums in any order: equal to rounding.
    EXPECT_LT((watched.T_scan_container.matrix() - plain.T_scan_container.matrix()).norm(), 1e-9);
    EXPECT_GT(never.looks(), plain.iterations);
}

// Without smoothing, each stage looks twice while it prepares its target and once before each
// iteration: a stop at the 5th look comes before the coarse stage's 3rd iteration. The pose
// reached by then comes back, not converged and without the fit's figures.
TEST(IcpTest, AStopEndsTheIterationsWithThePoseReached) {
    const MovedObject moved = Moved();
    AlignConfig config;
    config.smoothing_radius_m = 0.0;
    const AlignResult full =
        Align(moved.source.points, moved.source.normals, moved.scan, Pose::Identity(), config);
    ASSERT_TRUE(full.converged);
    ASSERT_GT(full.iterations, 4);
    const test::CountingStop cancel(5);
    const AlignResult stopped = Align(moved.source.points, moved.source.normals, moved.scan,
                                      Pose::Identity(), config, nullptr, cancel.token());
    EXPECT_EQ(stopped.iterations, 2);
    EXPECT_FALSE(stopped.converged);
    EXPECT_EQ(stopped.correspondences, 0u);
    const auto off = [&](const Pose& T) {
        return (moved.truth.inverse() * T).translation().norm();
    };
    EXPECT_LT(off(stopped.T_scan_container), 0.5 * off(Pose::Identity()));
    EXPECT_FALSE(CheckAlignment(stopped, AlignGate{}).ok());
}

TEST(IcpTest, AStopBeforeTheFirstIterationLeavesTheInitialPose) {
    const MovedObject moved = Moved();
    const AlignResult stopped =
        Align(moved.source.points, moved.source.normals, moved.scan, Pose::Identity(),
              AlignConfig{}, nullptr, StopToken(StopToken::Clock::now()));
    EXPECT_EQ(stopped.iterations, 0);
    EXPECT_FALSE(stopped.converged);
    EXPECT_TRUE(stopped.T_scan_container.isApprox(Pose::Identity()));
}

TEST(IcpTest, EmptyInputsGiveAnUnconvergedResultThatTheGateRefuses) {
    const AlignResult r = Align({}, {}, Object(), Pose::Identity(), AlignConfig{});
    EXPECT_FALSE(r.converged);
    EXPECT_EQ(CheckAlignment(r, AlignGate{}).code(), absl::StatusCode::kFailedPrecondition);
    const Source source = MakeSource(Object());
    const AlignResult none = Align(source.points, source.normals, {}, Pose::Identity(), {});
    EXPECT_EQ(none.target_points, 0u);
    EXPECT_FALSE(CheckAlignment(none, AlignGate{}).ok());
}

}  // namespace
}  // namespace soilvol::align
