#include <cmath>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/strings/str_format.h"
#include "client/commands.hpp"
#include "client/shift_scene.hpp"
#include "client/table.hpp"

namespace soilvol::client {
namespace {

struct ShiftOptions {
    int trucks = 20;
    int min_passes = 4, max_passes = 6;
    std::uint64_t seed = 1;
    std::string prefix = "shift";
};

/// One truck's load as the shift ends: the truth against the passes and the body scan.
struct ShiftRow {
    std::string haul_unit;
    double true_m3 = 0.0;
    int unmeasured = 0;  ///< passes dumped after three refused scans
    v1::Load load;
};

// The shift against a live server: register the bucket and the body, then for each truck open
// a load, estimate its passes, close it and scan its body.
class ShiftRun {
  public:
    ShiftRun(const ShiftOptions& options, const GlobalOptions& global)
        : options_(options),
          json_(global.json),
          plan_(
              MakeShiftPlan(options.trucks, options.min_passes, options.max_passes, options.seed)),
          connection_(global) {}

    int Run() {
        if (!connection_.ok()) return kExitUsage;
        if (!Register()) return kExitRpcError;
        std::vector<ShiftRow> rows;
        for (int t = 0; t < options_.trucks; ++t) {
            std::optional<ShiftRow> row = Truck(t);
            if (!row) return kExitRpcError;
            rows.push_back(*std::move(row));
        }
        Print(rows);
        return kExitOk;
    }

  private:
    template <typename Request, typename Response, typename Method>
    bool Call(Method method, const Request& request, Response* response,
              grpc::StatusCode* code = nullptr) {
        const auto context = connection_.NewContext();
        const grpc::Status status = (connection_.Soil().*method)(context.get(), request, response);
        if (code != nullptr) *code = status.error_code();
        if (!status.ok()) ReportRpcError(status);
        return status.ok();
    }

    bool RegisterOne(const std::string& id, const DemoSetup& setup, double target_m3,
                     v1::Container* out) {
        const absl::StatusOr<DemoScan> empty = SimulateDemoScan(setup, 0.0, 0, "");
        if (!empty.ok()) return Failed(empty.status());
        v1::RegisterContainerRequest request;
        request.set_container_id(id);
        request.set_overwrite(true);
        *request.mutable_scan() = empty->scan;
        *request.mutable_opening() = empty->opening;
        // A second empty scan from the far side (the bucket curled towards the sensor, the
        // truck turned): one view leaves the walls facing away unseen, and the registration
        // warns of them.
        DemoSetup far_side = setup;
        far_side.view.azimuth_deg += 180.0;
        const absl::StatusOr<DemoScan> other = SimulateDemoScan(far_side, 0.0, 1, "");
        if (!other.ok()) return Failed(other.status());
        v1::EmptyScan* more = request.add_additional_scans();
        *more->mutable_scan() = other->scan;
        *more->mutable_opening() = other->opening;
        request.mutable_material()->set_name("overburden");
        request.mutable_material()->set_density_kg_m3(1600.0);
        request.mutable_material()->set_bulking_factor(1.25);
        if (target_m3 > 0.0) request.mutable_load_targets()->set_volume_m3(target_m3);
        if (!Call(&v1::SoilVolume::Stub::RegisterContainer, request, out)) return false;
        if (!json_) {
            std::cout << absl::StrFormat(
                "registered %s from 2 empty scans: struck %.3f +- %.3f m^3 (true %.3f m^3)\n", id,
                out->struck_capacity_m3(), out->struck_capacity_uncertainty_m3(),
                empty->struck_capacity_m3);
            for (const std::string& warning : out->warnings()) {
                std::cout << "warning: " << warning << "\n";
            }
        }
        return true;
    }

    bool Register() {
        v1::Container bucket, body;
        if (!RegisterOne(BucketId(), plan_.bucket, 0.0, &bucket)) return false;
        // The body's target: five heaped buckets.
        const double target = 5.0 * bucket.heaped_capacity_m3();
        if (!RegisterOne(BodyId(), plan_.body, target, &body)) return false;
        if (!json_) {
            std::cout << absl::StrFormat(
                "shift of %d trucks: bucket %s (heaped %.2f m^3), body %s (struck %.2f m^3, "
                "target %.2f m^3)\n",
                options_.trucks, BucketId(), bucket.heaped_capacity_m3(), BodyId(),
                body.struck_capacity_m3(), target);
        }
        return true;
    }

    bool Failed(const absl::Status& status) {
        std::cerr << "error: simulation failed: " << status << "\n";
        return false;
    }

    /// Estimates the scan `simulate(attempt)` makes; a refused scan (FAILED_PRECONDITION: the
    /// service could not know) is scanned again, up to twice, as an operator would. False when
    /// the call failed or the scan was refused three times (`refused` set).
    template <typename Simulate>
    bool Estimate(const std::string& container, Simulate simulate, const std::string& load,
                  double* true_m3, bool* refused = nullptr) {
        for (int attempt = 0; attempt < 3; ++attempt) {
            const absl::StatusOr<DemoScan> scan = simulate(attempt);
            if (!scan.ok()) return Failed(scan.status());
            v1::EstimateVolumeRequest request;
            request.set_container_id(container);
            *request.mutable_scan() = scan->scan;
            request.set_load_id(load);
            request.set_omit_heightmap(true);
            v1::EstimateVolumeResponse response;
            grpc::StatusCode code = grpc::StatusCode::OK;
            if (Call(&v1::SoilVolume::Stub::EstimateVolume, request, &response, &code)) {
                if (true_m3 != nullptr) *true_m3 += scan->true_volume_m3;
                return true;
            }
            if (code != grpc::StatusCode::FAILED_PRECONDITION) return false;
            ++refusals_;
            std::cerr << "the scan was refused: scanning again\n";
        }
        if (refused != nullptr) *refused = true;
        return false;
    }

    std::optional<ShiftRow> Truck(int t) {
        ShiftRow row;
        row.haul_unit = absl::StrFormat("%s-truck-%02d", options_.prefix, t + 1);
        v1::CreateLoadRequest create;
        create.set_request_id(absl::StrFormat("%s-%d-%d", options_.prefix, options_.seed, t));
        create.mutable_load()->set_haul_unit_id(row.haul_unit);
        create.mutable_load()->set_body_container_id(BodyId());
        v1::Load load;
        if (!Call(&v1::SoilVolume::Stub::CreateLoad, create, &load)) return std::nullopt;
        for (std::size_t p = 0; p < plan_.trucks[t].pass_fills.size(); ++p) {
            const auto pass = [&](int attempt) {
                return SimulatePass(plan_, t, static_cast<int>(p), attempt);
            };
            bool refused = false;
            if (!Estimate(BucketId(), pass, load.load_id(), &row.true_m3, &refused)) {
                if (!refused) return std::nullopt;
                // Refused three times: the bucket is dumped unmeasured (the body scan will
                // show it missing from the passes).
                const absl::StatusOr<DemoScan> dumped = pass(0);
                if (dumped.ok()) row.true_m3 += dumped->true_volume_m3;
                ++row.unmeasured;
            }
        }
        v1::CloseLoadRequest close;
        close.set_load_id(load.load_id());
        if (!Call(&v1::SoilVolume::Stub::CloseLoad, close, &load)) return std::nullopt;
        // The truck leaves past the body's sensor.
        const double true_m3 = row.true_m3;
        const auto body = [&](int attempt) { return SimulateBody(plan_, t, true_m3, attempt); };
        bool refused = false;
        if (!Estimate(BodyId(), body, load.load_id(), nullptr, &refused) && !refused) {
            return std::nullopt;  // refused three times: the load goes without a body scan
        }
        v1::GetLoadRequest get;
        get.set_load_id(load.load_id());
        if (!Call(&v1::SoilVolume::Stub::GetLoad, get, &row.load)) return std::nullopt;
        return row;
    }

    void Print(const std::vector<ShiftRow>& rows) const;

    std::string BucketId() const { return options_.prefix + "-excavator"; }
    std::string BodyId() const { return options_.prefix + "-truck-body"; }

    const ShiftOptions& options_;
    const bool json_;
    const ShiftPlan plan_;
    Connection connection_;
    int refusals_ = 0;
};

void ShiftRun::Print(const std::vector<ShiftRow>& rows) const {
    int agree = 0, covered = 0, reconciled = 0;
    std::string json = "[";
    Table table({"haul unit", "load", "passes", "true [m^3]", "passes [m^3]", "1-sigma [L]",
                 "body [m^3]", "1-sigma [L]", "body-passes [sigma]", "status"});
    for (const ShiftRow& row : rows) {
        const v1::Load& l = row.load;
        const v1::LoadReconciliation& r = l.reconciliation();
        agree += r.within_two_sigma() ? 1 : 0;
        reconciled += l.has_reconciliation() ? 1 : 0;
        covered += std::abs(l.volume_m3() - row.true_m3) <= 2.0 * l.uncertainty_m3() ? 1 : 0;
        table.AddRow({row.haul_unit, l.load_id(), absl::StrCat(l.pass_count()),
                      Fixed(row.true_m3, 3), Fixed(l.volume_m3(), 3),
                      Fixed(1000.0 * l.uncertainty_m3(), 1), Fixed(r.body_volume_m3(), 3),
                      Fixed(1000.0 * r.body_uncertainty_m3(), 1), Fixed(r.difference_sigmas(), 2),
                      v1::LoadStatus_Name(l.assessment().status()).substr(12)});
        absl::StrAppendFormat(
            &json,
            "%s{\"haulUnitId\":\"%s\",\"loadId\":\"%s\",\"passes\":%d,\"unmeasured\":%d,"
            "\"trueM3\":%.6f,"
            "\"passesM3\":%.6f,\"passesSigmaM3\":%.6f,\"bodyM3\":%.6f,\"bodySigmaM3\":%.6f,"
            "\"differenceSigmas\":%.4f,\"withinTwoSigma\":%s,\"reconciled\":%s}",
            json.size() > 1 ? "," : "", row.haul_unit, l.load_id(), l.pass_count(), row.unmeasured,
            row.true_m3, l.volume_m3(), l.uncertainty_m3(), r.body_volume_m3(),
            r.body_uncertainty_m3(), r.difference_sigmas(), r.within_two_sigma() ? "true" : "false",
            l.has_reconciliation() ? "true" : "false");
    }
    if (json_) {
        std::cout << json << "]\n";
        return;
    }
    table.Print(std::cout);
    std::cout << absl::StrFormat(
        "body scan within 2 sigma of the passes: %d of %d reconciled loads (%zu loads); passes' "
        "sum within 2 sigma of the truth: %d of %zu; refused scans: %d\n",
        agree, reconciled, rows.size(), covered, rows.size(), refusals_);
}

}  // namespace

void AddShiftDemoCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto options = std::make_shared<ShiftOptions>();
    auto* command = app.add_subcommand(
        "demo-shift",
        "a simulated shift: an excavator loads trucks pass by pass, each body scanned at the "
        "exit (keeps what it makes)");
    command->add_option("--trucks", options->trucks, "trucks loaded")
        ->check(CLI::Range(1, 500))
        ->capture_default_str();
    command->add_option("--min-passes", options->min_passes, "fewest passes per truck")
        ->check(CLI::Range(1, 20))
        ->capture_default_str();
    command->add_option("--max-passes", options->max_passes, "most passes per truck")
        ->check(CLI::Range(1, 20))
        ->capture_default_str();
    command->add_option("--seed", options->seed, "seeds the shift")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    command
        ->add_option("--prefix", options->prefix,
                     "names the containers <prefix>-excavator and <prefix>-truck-body and "
                     "the haul units <prefix>-truck-NN")
        ->capture_default_str();
    command->callback([options, &global, exit_code] {
        if (options->max_passes < options->min_passes) {
            std::cerr << "error: --max-passes is below --min-passes\n";
            *exit_code = kExitUsage;
            return;
        }
        *exit_code = ShiftRun(*options, global).Run();
    });
}

}  // namespace soilvol::client
