#include <chrono>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/commands.hpp"
#include "client/demo_files.hpp"
#include "client/demo_scene.hpp"
#include "client/demo_table.hpp"

namespace soilvol::client {
namespace {

struct DemoOptions {
    sim::ContainerKind kind = sim::ContainerKind::kPaperBucket;
    std::string container = "paper";
    bool stereo = false;
    bool depth = false;
    std::vector<double> fills = {0.0, 0.25, 0.5, 0.75, 1.0};
    uint64_t seed = 1;
    bool keep = false;
    std::string save_dir;
};

DemoSensor SensorOf(const DemoOptions& options) {
    if (options.stereo) return DemoSensor::kStereo;
    return options.depth ? DemoSensor::kDepth : DemoSensor::kCloud;
}

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
        .count();
}

// The demo against a live server: calibrate (stereo), register, estimate each fill, clean up.
class DemoRun {
  public:
    DemoRun(const DemoOptions& options, const GlobalOptions& global)
        : options_(options),
          text_(!global.json),
          setup_(MakeDemoSetup(options.kind, SensorOf(options), options.seed)),
          id_("demo-" + options.container + (options.stereo ? "-stereo" : "") +
              (options.depth ? "-depth" : "")),
          connection_(global) {
        if (text_) {
            std::cout << "soilvol demo against " << global.server << ": " << DescribeDemo(setup_)
                      << "\n";
        }
    }

    int Run() {
        if (!connection_.ok()) return kExitUsage;
        const bool calibrated = !options_.stereo || Calibrate();
        const bool registered = calibrated && Register();
        std::vector<DemoRow> rows;
        for (size_t i = 0; registered && i < options_.fills.size(); ++i) {
            Estimate(options_.fills[i], 1 + i, &rows);
        }
        if (registered) PrintDemoRows(rows, !text_, std::cout);
        if (!options_.keep) CleanUp(registered, options_.stereo && calibrated);
        if (options_.keep && registered && text_) std::cout << "kept " << id_ << "\n";
        return ok_ ? kExitOk : kExitRpcError;
    }

  private:
    // One RPC with a fresh deadline; prints the error and clears ok_ when it fails.
    template <typename Request, typename Response, typename Method>
    bool Call(Method method, const Request& request, Response* response,
              std::string* error = nullptr) {
        const auto context = connection_.NewContext();
        const grpc::Status status = (connection_.Soil().*method)(context.get(), request, response);
        if (!status.ok()) {
            ReportRpcError(status);
            ok_ = false;
            if (error != nullptr) {
                *error = StatusCodeName(status.error_code()) + ": " + status.error_message();
            }
        }
        return status.ok();
    }

    // The scan, also written to --save-dir as <stem>.* when given.
    std::optional<DemoScan> Simulate(double fill_share, uint64_t scan_index,
                                     const std::string& stem) {
        absl::StatusOr<DemoScan> scan = SimulateDemoScan(setup_, fill_share, scan_index, id_);
        if (scan.ok() && !options_.save_dir.empty()) {
            const absl::Status saved = SaveDemoScan(options_.save_dir, stem, *scan);
            if (!saved.ok()) std::cerr << "warning: " << saved.message() << "\n";
        }
        if (scan.ok()) return *std::move(scan);
        std::cerr << "error: simulation failed: " << scan.status() << "\n";
        ok_ = false;
        return std::nullopt;
    }

    bool Calibrate() {
        v1::CalibrateRequest request;
        request.set_calibration_id(id_);
        request.set_overwrite(true);
        *request.mutable_parameters() = DemoRigParameters(setup_);
        if (!options_.save_dir.empty()) {
            const absl::Status saved = SaveDemoParameters(options_.save_dir, request.parameters());
            if (!saved.ok()) std::cerr << "warning: " << saved.message() << "\n";
        }
        v1::Calibration calibration;
        if (!Call(&v1::SoilVolume::Stub::Calibrate, request, &calibration)) return false;
        if (text_) {
            std::cout << absl::StrFormat("calibration %s: baseline %.4f m, focal length %.1f px\n",
                                         id_, calibration.baseline_m(),
                                         calibration.focal_length_px());
        }
        return true;
    }

    bool Register() {
        const std::optional<DemoScan> empty = Simulate(0.0, 0, "empty");
        if (!empty) return false;
        if (!options_.save_dir.empty() && setup_.sensor == DemoSensor::kCloud) {
            const absl::Status saved =
                SaveDemoMesh(options_.save_dir, MakeDemoMesh(setup_), empty->container_pose,
                             setup_.view.range_noise_sigma_m);
            if (!saved.ok()) std::cerr << "warning: " << saved.message() << "\n";
        }
        v1::RegisterContainerRequest request;
        request.set_container_id(id_);
        request.set_overwrite(true);
        *request.mutable_scan() = empty->scan;
        *request.mutable_opening() = empty->opening;
        v1::Container c;
        const auto start = std::chrono::steady_clock::now();
        if (!Call(&v1::SoilVolume::Stub::RegisterContainer, request, &c)) return false;
        if (text_) {
            std::cout << absl::StrFormat(
                "registered %s: struck %.1f L (true %.1f L), heaped SAE %.1f L (true %.1f L), "
                "%d points, %.0f ms\n",
                id_, c.struck_capacity_m3() * kLitre, empty->struck_capacity_m3 * kLitre,
                c.heaped_capacity_m3() * kLitre, empty->heaped_capacity_m3 * kLitre,
                c.scan_points(), MillisecondsSince(start));
            for (const std::string& warning : c.warnings()) {
                std::cout << "warning: " << warning << "\n";
            }
        }
        return true;
    }

    void Estimate(double fill_share, uint64_t scan_index, std::vector<DemoRow>* rows) {
        std::optional<DemoScan> scan =
            Simulate(fill_share, scan_index, absl::StrFormat("fill-%g", 100 * fill_share));
        if (!scan) return;
        v1::EstimateVolumeRequest request;
        request.set_container_id(id_);
        request.set_request_id(absl::StrFormat("fill-%g", fill_share));
        *request.mutable_scan() = std::move(scan->scan);
        DemoRow row{fill_share,
                    scan->true_volume_m3,
                    scan->struck_capacity_m3,
                    v1::EstimateVolumeResponse(),
                    "",
                    0.0};
        const auto start = std::chrono::steady_clock::now();
        if (!Call(&v1::SoilVolume::Stub::EstimateVolume, request, &*row.estimate, &row.error)) {
            row.estimate.reset();
        }
        row.round_trip_ms = MillisecondsSince(start);
        rows->push_back(std::move(row));
    }

    void CleanUp(bool container, bool calibration) {
        if (container) {
            v1::DeleteContainerRequest request;
            request.set_container_id(id_);
            v1::DeleteContainerResponse response;
            Call(&v1::SoilVolume::Stub::DeleteContainer, request, &response);
        }
        if (calibration) {
            v1::DeleteCalibrationRequest request;
            request.set_calibration_id(id_);
            v1::DeleteCalibrationResponse response;
            Call(&v1::SoilVolume::Stub::DeleteCalibration, request, &response);
        }
    }

    const DemoOptions& options_;
    const bool text_;
    const DemoSetup setup_;
    const std::string id_;
    Connection connection_;
    bool ok_ = true;
};

}  // namespace

void AddDemoCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto options = std::make_shared<DemoOptions>();
    auto* command = app.add_subcommand(
        "demo", "register a simulated empty container, then estimate simulated fills");
    const std::map<std::string, sim::ContainerKind> kinds = {
        {"paper", sim::ContainerKind::kPaperBucket},
        {"excavator", sim::ContainerKind::kExcavatorBucket},
        {"truck", sim::ContainerKind::kTruckBed}};
    command->add_option("--container", options->container, "paper, excavator or truck")
        ->check(CLI::IsMember({"paper", "excavator", "truck"}))
        ->capture_default_str();
    auto* stereo =
        command->add_flag("--stereo", options->stereo, "rendered stereo pairs instead of clouds");
    command
        ->add_flag("--depth", options->depth,
                   "a 640x480 ToF camera's 16-bit depth images instead of clouds")
        ->excludes(stereo);
    command->add_option("--fills", options->fills, "fills as shares of the container depth")
        ->delimiter(',')
        ->check(CLI::Range(0.0, 2.0))
        ->capture_default_str();
    command->add_option("--seed", options->seed, "seeds the simulated scenes")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    command->add_flag("--keep", options->keep, "keep the container and calibration afterwards");
    command->add_option("--save-dir", options->save_dir,
                        "also write the simulated scans, corners, poses, the container's mesh, "
                        "rig parameters and depth camera here");
    command->callback([options, kinds, &global, exit_code] {
        options->kind = kinds.at(options->container);
        *exit_code = DemoRun(*options, global).Run();
    });
}

}  // namespace soilvol::client
