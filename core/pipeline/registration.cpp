#include "core/pipeline/registration.hpp"

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/cloud/preprocess.hpp"
#include "core/common/status_macros.hpp"
#include "core/model/opening.hpp"

namespace soilvol::pipeline {
namespace {

// Where alignment of a later scan starts: its own corners when marked, else the first pose.
absl::StatusOr<Pose> InitialPose(const EmptyScan& scan, const model::ContainerModel& model,
                                 const model::ModelConfig& config, std::size_t index) {
    if (!scan.corners) return model.opening.T_scan_container;
    const cloud::PreprocessResult pre = cloud::Preprocess(scan.points, config.preprocess);
    auto opening = model::MakeOpening(*scan.corners, pre.points, config.opening);
    if (!opening.ok()) {
        return absl::InvalidArgumentError(
            absl::StrCat("empty scan ", index + 1, ": ", opening.status().message()));
    }
    return opening->T_scan_container;
}

}  // namespace

absl::StatusOr<Registration> RegisterContainer(const Corners& corners,
                                               const std::vector<EmptyScan>& scans,
                                               const RegistrationConfig& config) {
    if (scans.empty()) return absl::InvalidArgumentError("no empty scan to register");
    if (scans.size() > config.max_scans) {
        return absl::InvalidArgumentError(absl::StrCat(
            "additional_scans: at most ", config.max_scans - 1, " (got ", scans.size() - 1, ")"));
    }
    Registration out;
    SOILVOL_ASSIGN_OR_RETURN(out.model,
                             model::BuildContainerModel(scans[0].points, corners, config.model));
    for (std::size_t i = 1; i < scans.size(); ++i) {
        SOILVOL_ASSIGN_OR_RETURN(const Pose initial,
                                 InitialPose(scans[i], out.model, config.model, i));
        align::AlignConfig align = config.align;
        align.smoothing_radius_m = std::max(align.smoothing_radius_m, out.model.smoothing_radius_m);
        const cloud::PreprocessResult pre =
            cloud::Preprocess(scans[i].points, config.model.preprocess);
        const align::ContentColumn column = model::ContentColumnOf(out.model);
        align::AlignResult alignment =
            align::Align(out.model.alignment_points, out.model.alignment_normals, pre.points,
                         initial, align, &column);
        if (const absl::Status gate = align::CheckAlignment(alignment, config.gate); !gate.ok()) {
            return absl::FailedPreconditionError(
                absl::StrCat("empty scan ", i + 1, ": ", gate.message()));
        }
        SOILVOL_RETURN_IF_ERROR(model::AddEmptyScan(scans[i].points, alignment.T_scan_container,
                                                    config.model, out.model));
        out.alignments.push_back(std::move(alignment));
    }
    return out;
}

}  // namespace soilvol::pipeline
