#include "core/align/global_align.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "core/align/icp.hpp"
#include "core/cloud/local_surface.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/angles.hpp"
#include "tests/core/align/test_object.hpp"

namespace soilvol::align {
namespace {

Cloud Noisy(const Cloud& c, const Pose& T, double sigma, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<float> n(0.0f, static_cast<float>(sigma));
    Cloud out;
    for (const auto& p : c) {
        out.push_back((T * p.cast<double>()).cast<float>() +
                      Eigen::Vector3f(n(rng), n(rng), n(rng)));
    }
    return out;
}

double TurnDeg(const Pose& a, const Pose& b) {
    return Eigen::AngleAxisd((a.inverse() * b).linear()).angle() * 180.0 / kPi;
}

// Large moves from the registered pose (50 deg and 0.6 m), with no start at all: the global
// search lands near enough for ICP to finish within the noise.
TEST(GlobalAlignTest, FindsLargeMovesNearEnoughForIcp) {
    const Cloud object = Object();
    Pose registered = Pose::Identity();
    registered.translation() = Eigen::Vector3d(0.1, -0.2, 3.0);
    const Eigen::Vector3d sensor_in_container = registered.inverse() * Eigen::Vector3d::Zero();
    const cloud::LocalSurface model = SmoothedAsModel(object);
    for (const double yaw_deg : {50.0, -35.0}) {
        Pose move = Pose::Identity();
        move.linear() =
            Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        move.translation() = Eigen::Vector3d(0.5, -0.3, 0.1);
        const Pose truth = registered * move;
        const Cloud scan = Noisy(object, truth, 0.005, 3);
        // The box is nearly symmetric: the pose turned half way round explains it almost as
        // well, and the reference (the registered pose) tells the move from the flip.
        const auto coarse = GlobalAlign(model.points, sensor_in_container, scan, {}, registered);
        ASSERT_TRUE(coarse.has_value()) << yaw_deg;
        EXPECT_LT((coarse->translation() - truth.translation()).norm(), 0.15) << yaw_deg;
        EXPECT_LT(TurnDeg(*coarse, truth), 10.0) << yaw_deg;
        const AlignResult refined =
            Align(model.points, model.normals, scan, *coarse, AlignConfig{});
        EXPECT_LT((refined.T_scan_container.translation() - truth.translation()).norm(), 0.01)
            << yaw_deg;
        EXPECT_LT(TurnDeg(refined.T_scan_container, truth), 0.5) << yaw_deg;
    }
}

// A pose is returned only when it explains the asked share of the model: a scan that holds
// half of the object cannot explain 90% of it, and does explain 30%.
TEST(GlobalAlignTest, PoseMustExplainTheAskedShareOfTheModel) {
    const Cloud object = Object();
    Pose placed = Pose::Identity();
    placed.translation() = Eigen::Vector3d(0.0, 0.0, 3.0);
    Cloud half;
    for (const auto& p : Noisy(object, placed, 0.003, 5)) {
        if (p.x() < 0.0f) half.push_back(p);
    }
    const cloud::LocalSurface model = SmoothedAsModel(object);
    const Eigen::Vector3d sensor(0.0, 0.0, -3.0);
    GlobalAlignConfig strict;
    strict.min_inlier_fraction = 0.9;
    EXPECT_FALSE(GlobalAlign(model.points, sensor, half, strict).has_value());
    const auto loose = GlobalAlign(model.points, sensor, half, {});
    ASSERT_TRUE(loose.has_value());
    const AlignResult refined = Align(model.points, model.normals, half, *loose, AlignConfig{});
    EXPECT_LT((refined.T_scan_container.translation() - placed.translation()).norm(), 0.02);
}

}  // namespace
}  // namespace soilvol::align
