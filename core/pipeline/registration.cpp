#include "core/pipeline/registration.hpp"

#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "core/cloud/preprocess.hpp"
#include "core/common/status_macros.hpp"
#include "core/model/mesh_model.hpp"
#include "core/model/opening.hpp"

namespace soilvol::pipeline {
namespace {

// Where alignment of a later scan starts: its own corners when marked, else the first pose.
absl::StatusOr<Pose> InitialPose(const EmptyScan& scan, const Cloud& preprocessed,
                                 const model::ContainerModel& model,
                                 const model::ModelConfig& config, std::size_t index) {
    if (!scan.corners) return model.opening.T_scan_container;
    auto opening = model::MakeOpening(*scan.corners, preprocessed, config.opening);
    if (!opening.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("empty scan ", index + 1, ": ", opening.status().message()));
    }
    return opening->T_scan_container;
}

// Every sensor's returns of `scan`, each preprocessed from where it stood, in the scan frame.
Cloud InScanFrame(const EmptyScan& scan, const cloud::PreprocessConfig& config,
                  const StopToken& stop) {
    Cloud all = cloud::Preprocess(scan.points, config, stop).points;
    for (const SensorCloud& more : scan.more_sensors) {
        const Cloud placed = model::ToScanFrame(cloud::Preprocess(more.points, config, stop).points,
                                                more.T_scan_sensor);
        all.insert(all.end(), placed.begin(), placed.end());
    }
    return all;
}

}  // namespace

absl::StatusOr<Registration> RegisterContainer(const Corners& corners,
                                               const std::vector<EmptyScan>& scans,
                                               const RegistrationConfig& config,
                                               const StopToken& stop) {
    if (scans.empty()) return absl::InvalidArgumentError("no empty scan to register");
    if (scans.size() > config.max_scans) {
        return absl::InvalidArgumentError(absl::StrCat(
            "additional_scans: at most ", config.max_scans - 1, " (got ", scans.size() - 1, ")"));
    }
    Registration out;
    SOILVOL_ASSIGN_OR_RETURN(
        out.model, model::BuildContainerModel(scans[0].points, scans[0].more_sensors, corners,
                                              config.model, stop));
    for (std::size_t i = 1; i < scans.size(); ++i) {
        const std::string scan = absl::StrCat(" (empty scan ", i + 1, " of ", scans.size(), ")");
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("preprocessing", scan)));
        const Cloud points = InScanFrame(scans[i], config.model.preprocess, stop);
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("preprocessing", scan)));
        SOILVOL_ASSIGN_OR_RETURN(const Pose initial,
                                 InitialPose(scans[i], points, out.model, config.model, i));
        align::AlignResult alignment =
            model::AlignModel(out.model, points, initial, config.align, stop);
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("alignment", scan)));
        if (const absl::Status gate = align::CheckAlignment(alignment, config.gate); !gate.ok()) {
            return absl::FailedPreconditionError(
                absl::StrCat("empty scan ", i + 1, ": ", gate.message()));
        }
        SOILVOL_RETURN_IF_ERROR(model::AddEmptyScan(scans[i].points, scans[i].more_sensors,
                                                    alignment.T_scan_container, config.model,
                                                    out.model, stop));
        out.alignments.push_back(std::move(alignment));
    }
    out.warnings = CapacityWarnings(out.model, config.max_capacity_sigma_share);
    return out;
}

absl::StatusOr<Registration> RegisterWithMesh(const MeshInput& mesh, const Corners& corners,
                                              const std::vector<EmptyScan>& scans,
                                              const std::optional<Pose>& T_scan_mesh,
                                              double range_noise_m,
                                              const RegistrationConfig& config,
                                              const StopToken& stop) {
    Registration out;
    if (scans.empty()) {
        if (!T_scan_mesh) {
            return absl::InvalidArgumentError(
                "container_pose: a mesh without an empty scan needs the container's pose in the "
                "sensor's frame");
        }
        model::MeshModelConfig mesh_config;
        mesh_config.model = config.model;
        SOILVOL_ASSIGN_OR_RETURN(
            out.model, model::BuildMeshModel(mesh.mesh, mesh.corners, *T_scan_mesh, range_noise_m,
                                             mesh_config, stop));
    } else {
        SOILVOL_ASSIGN_OR_RETURN(out, RegisterContainer(corners, scans, config, stop));
        SOILVOL_RETURN_IF_ERROR(
            model::AttachMesh(mesh.mesh, mesh.corners, config.model, out.model, 0.05, stop));
    }
    out.warnings = CapacityWarnings(out.model, config.max_capacity_sigma_share);
    return out;
}

std::vector<std::string> CapacityWarnings(const model::ContainerModel& model,
                                          double max_capacity_sigma_share) {
    std::vector<std::string> out;
    const double struck = model.struck_capacity_m3;
    if (!(struck > 0.0) || model.struck_capacity_sigma_m3 <= max_capacity_sigma_share * struck) {
        return out;
    }
    std::string message = absl::StrFormat(
        "the struck capacity's 1-sigma is %.1f L (%.2g%% of %.1f L, above %.2g%%)",
        1000.0 * model.struck_capacity_sigma_m3, 100.0 * model.struck_capacity_sigma_m3 / struck,
        1000.0 * struck, 100.0 * max_capacity_sigma_share);
    if (model.unseen.empty()) {
        absl::StrAppend(&message, ": register more empty scans");
    } else {
        // The inside along a side is hidden from a sensor beyond it: scan from across.
        const model::UnseenSide& side = model.unseen.front();
        absl::StrAppend(
            &message,
            absl::StrFormat(
                ": no empty scan saw %.2f m2 of the inside along the side from corner %d to "
                "corner %d (1-4 as marked; %.1f L of the 1-sigma); register another empty scan "
                "seen from beyond the opposite side (corners %d to %d), or the container's mesh",
                side.area_m2, side.from_corner + 1, side.to_corner + 1, 1000.0 * side.sigma_m3,
                (side.from_corner + 2) % 4 + 1, (side.to_corner + 2) % 4 + 1));
    }
    out.push_back(std::move(message));
    return out;
}

}  // namespace soilvol::pipeline
