#include "client/scan_options.hpp"

#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "client/input_files.hpp"
#include "core/common/status_macros.hpp"

namespace soilvol::client {
namespace {

// The --depth option and its camera; returns --depth.
CLI::Option* AddDepthOptions(CLI::App* command, DepthOptions* options, const std::string& what) {
    auto* depth = command->add_option(
        "--depth", options->depth,
        what + ": depth image (16-bit PNG/TIFF/PGM in --depth-unit, default mm; float TIFF, m)");
    auto* intrinsics =
        command->add_option("--intrinsics", options->intrinsics, "depth camera fx,fy,cx,cy [px]")
            ->delimiter(',')
            ->expected(4);
    const std::vector<CLI::Option*> extras = {
        command->add_option("--confidence", options->confidence,
                            "confidence or amplitude image of the depth image's size"),
        command->add_option("--min-confidence", options->min_confidence,
                            "drop pixels whose confidence is below this (as stored)"),
        command->add_option("--lens", options->lens, "pinhole, brown-conrady or kannala-brandt")
            ->check(CLI::IsMember({"pinhole", "brown-conrady", "kannala-brandt"})),
        command
            ->add_option("--distortion", options->distortion, "lens coefficients in OpenCV's order")
            ->delimiter(','),
        command->add_option(
            "--depth-unit", options->unit_m,
            "metres per stored depth unit (default: 0.001 for 16-bit, 1 for float)"),
        command->add_option("--depth-noise", options->noise_m,
                            "depth noise at 1 m, 1 sigma [m], for the flying-pixel filter (0.002)"),
        command->add_flag("--range-image", options->range,
                          "the depth image holds range along each ray, not z-depth"),
        command->add_flag("--keep-flying-pixels", options->keep_flying,
                          "keep the mixed returns at depth edges"),
    };
    depth->needs(intrinsics);
    intrinsics->needs(depth);
    for (CLI::Option* option : extras) option->needs(depth);
    return depth;
}

absl::StatusOr<v1::LensModel> LensOf(const std::string& name) {
    if (name == "pinhole") return v1::LENS_MODEL_PINHOLE;
    if (name == "brown-conrady") return v1::LENS_MODEL_BROWN_CONRADY;
    if (name == "kannala-brandt") return v1::LENS_MODEL_KANNALA_BRANDT;
    return absl::InvalidArgumentError(
        absl::StrCat("--lens: '", name, "' is not pinhole, brown-conrady or kannala-brandt"));
}

absl::StatusOr<v1::Scan> BuildDepthScan(const DepthOptions& options) {
    if (options.intrinsics.size() != 4) {
        return absl::InvalidArgumentError("--depth needs --intrinsics fx,fy,cx,cy");
    }
    v1::Scan scan;
    v1::DepthScan* depth = scan.mutable_depth();
    absl::StatusOr<std::string> image = ReadFile(options.depth);
    if (!image.ok()) return image.status();
    depth->set_depth(*std::move(image));
    if (!options.confidence.empty()) {
        absl::StatusOr<std::string> confidence = ReadFile(options.confidence);
        if (!confidence.ok()) return confidence.status();
        depth->set_confidence(*std::move(confidence));
    }
    depth->set_min_confidence(options.min_confidence);
    depth->set_depth_noise_m(options.noise_m);
    depth->set_keep_flying_pixels(options.keep_flying);
    v1::DepthCamera* camera = depth->mutable_camera();
    camera->set_fx(options.intrinsics[0]);
    camera->set_fy(options.intrinsics[1]);
    camera->set_cx(options.intrinsics[2]);
    camera->set_cy(options.intrinsics[3]);
    absl::StatusOr<v1::LensModel> lens = LensOf(options.lens);
    if (!lens.ok()) return lens.status();
    camera->set_lens(*lens);
    for (double c : options.distortion) camera->add_distortion(c);
    camera->set_meaning(options.range ? v1::DEPTH_MEANING_RANGE : v1::DEPTH_MEANING_Z);
    camera->set_depth_unit_m(options.unit_m);
    return scan;
}

void SetPose(const double* p, v1::Pose* pose) {
    pose->mutable_position_m()->set_x(p[0]);
    pose->mutable_position_m()->set_y(p[1]);
    pose->mutable_position_m()->set_z(p[2]);
    pose->mutable_orientation()->set_w(p[3]);
    pose->mutable_orientation()->set_x(p[4]);
    pose->mutable_orientation()->set_y(p[5]);
    pose->mutable_orientation()->set_z(p[6]);
}

// The other sensors' clouds, each with its pose when given.
absl::Status AddMoreClouds(const ScanOptions& options, v1::Scan& scan) {
    constexpr std::size_t kPose = 7;
    if (!options.more_poses.empty() &&
        options.more_poses.size() != kPose * options.more_clouds.size()) {
        return absl::InvalidArgumentError(
            absl::StrCat("--also-sensor-pose: give 7 numbers (x,y,z,qw,qx,qy,qz) for each of the ",
                         options.more_clouds.size(), " --also-cloud files (got ",
                         options.more_poses.size(), " numbers)"));
    }
    for (std::size_t i = 0; i < options.more_clouds.size(); ++i) {
        absl::StatusOr<std::string> data = ReadFile(options.more_clouds[i]);
        if (!data.ok()) return data.status();
        v1::CloudScan* cloud = scan.add_additional_sensors()->mutable_cloud();
        cloud->set_data(*std::move(data));
        if (!options.more_poses.empty()) {
            SetPose(&options.more_poses[kPose * i], cloud->mutable_sensor_pose());
        }
    }
    return absl::OkStatus();
}

}  // namespace

void AddScanOptions(CLI::App* command, ScanOptions* options, const std::string& what) {
    auto* cloud =
        command->add_option("--cloud", options->cloud, what + ": point cloud file (PLY or PCD)");
    auto* left = command->add_option("--left", options->left, what + ": left image of the pair");
    auto* right =
        command->add_option("--right", options->right, what + ": right image of the pair");
    auto* calibration = command->add_option("--calibration", options->calibration,
                                            "calibration id the pair was taken with");
    command
        ->add_option("--sensor-pose", options->sensor_pose,
                     "the sensor's pose in the cloud's frame: x,y,z [m],qw,qx,qy,qz (default: "
                     "a PCD's VIEWPOINT, else the cloud's origin)")
        ->delimiter(',')
        ->expected(7)
        ->needs(cloud);
    for (auto* stereo : {left, right, calibration}) cloud->excludes(stereo);
    left->needs(right, calibration);
    right->needs(left, calibration);
    calibration->needs(left, right);
    CLI::Option* depth = AddDepthOptions(command, &options->depth, what);
    for (auto* other : {cloud, left, right, calibration}) other->excludes(depth);
    auto* more = command->add_option(
        "--also-cloud", options->more_clouds,
        what +
            ": another sensor's cloud taken together with --cloud or --depth (repeat for "
            "more; poses in the first sensor's shared frame)");
    command
        ->add_option("--also-sensor-pose", options->more_poses,
                     "each --also-cloud's sensor pose in the shared frame, in order: "
                     "x,y,z,qw,qx,qy,qz per cloud (default: each cloud's own VIEWPOINT or "
                     "origin)")
        ->delimiter(',')
        ->needs(more);
    for (auto* stereo : {left, right, calibration}) more->excludes(stereo);
}

absl::StatusOr<v1::Scan> BuildScan(const ScanOptions& options) {
    v1::Scan scan;
    if (!options.cloud.empty()) {
        absl::StatusOr<std::string> data = ReadFile(options.cloud);
        if (!data.ok()) return data.status();
        scan.mutable_cloud()->set_data(*std::move(data));
        if (options.sensor_pose.size() == 7) {
            SetPose(options.sensor_pose.data(), scan.mutable_cloud()->mutable_sensor_pose());
        }
        SOILVOL_RETURN_IF_ERROR(AddMoreClouds(options, scan));
        return scan;
    }
    if (!options.depth.depth.empty()) {
        SOILVOL_ASSIGN_OR_RETURN(scan, BuildDepthScan(options.depth));
        SOILVOL_RETURN_IF_ERROR(AddMoreClouds(options, scan));
        return scan;
    }
    if (options.left.empty() || options.right.empty() || options.calibration.empty()) {
        return absl::InvalidArgumentError(
            "a scan needs --cloud FILE, --left FILE --right FILE --calibration ID, or --depth "
            "FILE --intrinsics fx,fy,cx,cy");
    }
    absl::StatusOr<std::string> left = ReadFile(options.left);
    if (!left.ok()) return left.status();
    absl::StatusOr<std::string> right = ReadFile(options.right);
    if (!right.ok()) return right.status();
    v1::StereoScan* stereo = scan.mutable_stereo();
    stereo->set_left(*std::move(left));
    stereo->set_right(*std::move(right));
    stereo->set_calibration_id(options.calibration);
    return scan;
}

}  // namespace soilvol::client
