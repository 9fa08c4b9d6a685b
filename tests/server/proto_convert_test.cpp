#include "proto/convert/proto_convert.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace soilvol::server {
namespace {

v1::StereoParameters Rig() {
    v1::StereoParameters p;
    p.set_image_width(640);
    p.set_image_height(480);
    for (v1::CameraIntrinsics* c : {p.mutable_left(), p.mutable_right()}) {
        c->set_fx(500);
        c->set_fy(501);
        c->set_cx(320);
        c->set_cy(240);
        for (double k : {0.1, -0.2, 0.001, 0.002}) c->add_distortion(k);
    }
    for (double r : {1, 0, 0, 0, 1, 0, 0, 0, 1}) p.add_rotation(r);
    for (double t : {-0.1, 0.0, 0.002}) p.add_translation_m(t);
    return p;
}

void ExpectInvalid(const absl::Status& status, const std::string& field) {
    EXPECT_TRUE(absl::IsInvalidArgument(status)) << status;
    EXPECT_EQ(status.message().substr(0, field.size()), field) << status.message();
}

TEST(ProtoConvert, StereoParametersRoundTrip) {
    const absl::StatusOr<StereoParameters> core = ToStereoParameters(Rig(), "parameters");
    ASSERT_TRUE(core.ok()) << core.status();
    EXPECT_DOUBLE_EQ(core->left.fy, 501);
    EXPECT_DOUBLE_EQ(core->t_right_left_m.z(), 0.002);
    v1::StereoParameters back;
    ToProto(*core, &back);
    EXPECT_EQ(back.SerializeAsString(), Rig().SerializeAsString());
}

TEST(ProtoConvert, StoredCalibrationRebuildsTheSameRig) {
    const absl::StatusOr<StereoParameters> parameters = ToStereoParameters(Rig(), "parameters");
    ASSERT_TRUE(parameters.ok());
    absl::StatusOr<stereo::StereoCalibration> original =
        stereo::CalibrationFromParameters(*parameters);
    ASSERT_TRUE(original.ok()) << original.status();
    original->source = "chessboard";
    original->rms_reprojection_px = 0.31;
    original->skipped.push_back({4, "left: chessboard 9x6 not found"});
    v1::Calibration stored;
    ToProto(*original, &stored);
    v1::Calibration read;  // through the bytes, as the store keeps them
    ASSERT_TRUE(read.ParseFromString(stored.SerializeAsString()));
    const absl::StatusOr<stereo::StereoCalibration> rebuilt = ToStereoCalibration(read);
    ASSERT_TRUE(rebuilt.ok()) << rebuilt.status();
    EXPECT_EQ((rebuilt->Q - original->Q).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ((rebuilt->P2 - original->P2).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ((rebuilt->R1 - original->R1).cwiseAbs().maxCoeff(), 0.0);
    EXPECT_EQ(rebuilt->baseline_m, original->baseline_m);
    EXPECT_EQ(rebuilt->source, "chessboard");
    EXPECT_EQ(rebuilt->rms_reprojection_px, 0.31);
    ASSERT_EQ(rebuilt->skipped.size(), 1u);
    EXPECT_EQ(rebuilt->skipped[0].index, 4);
}

TEST(ProtoConvert, StoredCalibrationWithBadParametersIsRefusedNamingTheField) {
    v1::Calibration stored;
    *stored.mutable_parameters() = Rig();
    stored.mutable_parameters()->mutable_left()->set_fx(-1.0);
    ExpectInvalid(ToStereoCalibration(stored).status(), "parameters.left.fx");
    stored.clear_parameters();
    EXPECT_FALSE(ToStereoCalibration(stored).ok());
}

TEST(ProtoConvert, StereoParameterCountsNameTheField) {
    v1::StereoParameters p = Rig();
    p.mutable_rotation()->RemoveLast();
    ExpectInvalid(ToStereoParameters(p, "parameters").status(), "parameters.rotation");
    p = Rig();
    p.add_translation_m(1.0);
    ExpectInvalid(ToStereoParameters(p, "parameters").status(), "parameters.translation_m");
    p = Rig();
    p.clear_left();
    ExpectInvalid(ToStereoParameters(p, "parameters").status(), "parameters.left");
}

TEST(ProtoConvert, DepthScanOptionsMapEveryEnumAndNameBadFields) {
    v1::DepthScan scan;
    v1::DepthCamera* camera = scan.mutable_camera();
    camera->set_fx(250);
    camera->set_fy(251);
    camera->set_cx(160);
    camera->set_cy(120);
    camera->set_lens(v1::LENS_MODEL_KANNALA_BRANDT);
    for (double k : {0.1, 0.01, 0.001, 0.0001}) camera->add_distortion(k);
    camera->set_meaning(v1::DEPTH_MEANING_RANGE);
    camera->set_depth_unit_m(0.0001);
    scan.set_min_confidence(30);
    scan.set_depth_noise_m(0.01);
    scan.set_keep_flying_pixels(true);
    auto options = ToDepthScanOptions(scan, "scan.depth");
    ASSERT_TRUE(options.ok()) << options.status();
    EXPECT_EQ(options->camera.lens, depth::LensModel::kKannalaBrandt);
    EXPECT_EQ(options->camera.meaning, depth::DepthMeaning::kRange);
    EXPECT_EQ(options->camera.intrinsics.distortion.size(), 4u);
    EXPECT_EQ(options->camera.intrinsics.fy, 251.0);
    EXPECT_EQ(options->camera.depth_unit_m, 0.0001);
    EXPECT_EQ(options->config.min_confidence, 30.0);
    EXPECT_EQ(options->config.flying.noise_at_1m_m, 0.01);
    EXPECT_FALSE(options->config.flying.enabled);
    // Unset: a pinhole z-depth camera, the filter on at its default noise.
    options = ToDepthScanOptions(v1::DepthScan(), "scan.depth");
    ASSERT_TRUE(options.ok());
    EXPECT_EQ(options->camera.lens, depth::LensModel::kPinhole);
    EXPECT_EQ(options->camera.meaning, depth::DepthMeaning::kZ);
    EXPECT_TRUE(options->config.flying.enabled);
    EXPECT_EQ(options->config.flying.noise_at_1m_m, depth::FlyingPixelConfig{}.noise_at_1m_m);

    v1::DepthScan bad = scan;
    bad.mutable_camera()->set_lens(static_cast<v1::LensModel>(9));
    ExpectInvalid(ToDepthScanOptions(bad, "scan.depth").status(), "scan.depth.camera.lens");
    bad = scan;
    bad.mutable_camera()->set_meaning(static_cast<v1::DepthMeaning>(-1));
    ExpectInvalid(ToDepthScanOptions(bad, "scan.depth").status(), "scan.depth.camera.meaning");
    bad = scan;
    bad.set_depth_noise_m(std::numeric_limits<double>::quiet_NaN());
    ExpectInvalid(ToDepthScanOptions(bad, "scan.depth").status(), "scan.depth.depth_noise_m");
    bad = scan;
    bad.set_min_confidence(std::numeric_limits<double>::infinity());
    ExpectInvalid(ToDepthScanOptions(bad, "scan.depth").status(), "scan.depth.min_confidence");
}

TEST(ProtoConvert, OpeningNeedsExactlyOneKindOfFourCorners) {
    v1::Opening opening;
    ExpectInvalid(ToOpeningMarks(opening, false).status(), "opening");
    for (int i = 0; i < 3; ++i) opening.add_corners()->set_x(i);
    ExpectInvalid(ToOpeningMarks(opening, false).status(), "opening.corners");
    opening.add_corners()->set_y(1);
    ASSERT_TRUE(ToOpeningMarks(opening, false).ok());
    EXPECT_TRUE(std::holds_alternative<Corners>(*ToOpeningMarks(opening, false)));
    opening.mutable_corners(2)->set_z(std::nan(""));
    ExpectInvalid(ToOpeningMarks(opening, false).status(), "opening.corners[2]");

    v1::Opening pixels;
    for (int i = 0; i < 4; ++i) pixels.add_pixel_corners()->set_u(10 * i);
    ExpectInvalid(ToOpeningMarks(pixels, false).status(), "opening.pixel_corners");
    ASSERT_TRUE(ToOpeningMarks(pixels, true).ok());
    EXPECT_TRUE(std::holds_alternative<stereo::PixelCorners>(*ToOpeningMarks(pixels, true)));
    pixels.mutable_pixel_corners(1)->set_v(std::numeric_limits<double>::infinity());
    ExpectInvalid(ToOpeningMarks(pixels, true).status(), "opening.pixel_corners[1]");
    *pixels.add_corners() = v1::Point3();
    ExpectInvalid(ToOpeningMarks(pixels, true).status(), "opening");
}

TEST(ProtoConvert, ChessboardSpecIsChecked) {
    v1::ChessboardCalibration board;
    ExpectInvalid(ToChessboardSpec(board).status(), "chessboard.inner_corners");
    board.mutable_inner_corners()->set_cols(9);
    board.mutable_inner_corners()->set_rows(6);
    ExpectInvalid(ToChessboardSpec(board).status(), "chessboard.pairs");
    board.add_pairs();
    ExpectInvalid(ToChessboardSpec(board).status(), "chessboard.square_size_m");
    board.set_square_size_m(0.025);
    ASSERT_TRUE(ToChessboardSpec(board).ok());
    board.mutable_inner_corners()->set_rows(1);
    ExpectInvalid(ToChessboardSpec(board).status(), "chessboard.inner_corners");
    board.mutable_inner_corners()->set_rows(6);
    board.set_square_size_m(std::nan(""));
    ExpectInvalid(ToChessboardSpec(board).status(), "chessboard.square_size_m");
}

TEST(ProtoConvert, ContainerCarriesTheCapacitysUncertaintyUnseenSidesAndMesh) {
    model::ContainerModel model;
    model.struck_capacity_m3 = 0.66;
    model.struck_capacity_sigma_m3 = 0.017;
    model.unseen = {{0, 1, 0.2, 0.016}, {1, 2, 0.005, 0.001}};
    v1::Container proto;
    proto.add_unseen_sides();  // replaced, not appended to
    ToProto(model, &proto);
    EXPECT_DOUBLE_EQ(proto.struck_capacity_uncertainty_m3(), 0.017);
    ASSERT_EQ(proto.unseen_sides_size(), 2);
    EXPECT_EQ(proto.unseen_sides(0).from_corner(), 0);
    EXPECT_EQ(proto.unseen_sides(0).to_corner(), 1);
    EXPECT_DOUBLE_EQ(proto.unseen_sides(0).area_m2(), 0.2);
    EXPECT_DOUBLE_EQ(proto.unseen_sides(1).uncertainty_m3(), 0.001);
    EXPECT_FALSE(proto.has_mesh());
    model.mesh.vertices = {Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(),
                           Eigen::Vector3d::UnitY()};
    model.mesh.triangles = {Eigen::Vector3i(0, 1, 2)};
    ToProto(model, &proto);
    EXPECT_TRUE(proto.has_mesh());
}

}  // namespace
}  // namespace soilvol::server
