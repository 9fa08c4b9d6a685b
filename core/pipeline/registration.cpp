#include "core/pipeline/registration.hpp"

#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/cloud/preprocess.hpp"
#include "core/common/status_macros.hpp"
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
        out.model, model::BuildContainerModel(scans[0].points, corners, config.model, stop));
    for (std::size_t i = 1; i < scans.size(); ++i) {
        const std::string scan = absl::StrCat(" (empty scan ", i + 1, " of ", scans.size(), ")");
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("preprocessing", scan)));
        const cloud::PreprocessResult pre =
            cloud::Preprocess(scans[i].points, config.model.preprocess, stop);
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("preprocessing", scan)));
        SOILVOL_ASSIGN_OR_RETURN(const Pose initial,
                                 InitialPose(scans[i], pre.points, out.model, config.model, i));
        align::AlignResult alignment =
            model::AlignModel(out.model, pre.points, initial, config.align, stop);
        SOILVOL_RETURN_IF_ERROR(stop.Check(absl::StrCat("alignment", scan)));
        if (const absl::Status gate = align::CheckAlignment(alignment, config.gate); !gate.ok()) {
            return absl::FailedPreconditionError(
                absl::StrCat("empty scan ", i + 1, ": ", gate.message()));
        }
        SOILVOL_RETURN_IF_ERROR(model::AddEmptyScan(scans[i].points, alignment.T_scan_container,
                                                    config.model, out.model, stop));
        out.alignments.push_back(std::move(alignment));
    }
    return out;
}

}  // namespace soilvol::pipeline
