#include "client/scan_options.hpp"

#include "absl/status/status.h"
#include "client/input_files.hpp"

namespace soilvol::client {

void AddScanOptions(CLI::App* command, ScanOptions* options, const std::string& what) {
    auto* cloud =
        command->add_option("--cloud", options->cloud, what + ": point cloud file (PLY or PCD)");
    auto* left = command->add_option("--left", options->left, what + ": left image of the pair");
    auto* right =
        command->add_option("--right", options->right, what + ": right image of the pair");
    auto* calibration = command->add_option("--calibration", options->calibration,
                                            "calibration id the pair was taken with");
    for (auto* stereo : {left, right, calibration}) cloud->excludes(stereo);
    left->needs(right, calibration);
    right->needs(left, calibration);
    calibration->needs(left, right);
}

absl::StatusOr<v1::Scan> BuildScan(const ScanOptions& options) {
    v1::Scan scan;
    if (!options.cloud.empty()) {
        absl::StatusOr<std::string> data = ReadFile(options.cloud);
        if (!data.ok()) return data.status();
        scan.mutable_cloud()->set_data(*std::move(data));
        return scan;
    }
    if (options.left.empty() || options.right.empty() || options.calibration.empty()) {
        return absl::InvalidArgumentError(
            "a scan needs --cloud FILE or --left FILE --right FILE --calibration ID");
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
