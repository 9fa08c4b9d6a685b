#include "client/response_printer.hpp"

#include <google/protobuf/util/json_util.h>
#include <google/protobuf/util/time_util.h>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/table.hpp"

namespace soilvol::client {
namespace {

std::string Source(v1::CalibrationSource source) {
    return EnumLabel(v1::CalibrationSource_Name(source), "CALIBRATION_SOURCE_");
}

std::string Kind(v1::ScanKind kind) { return EnumLabel(v1::ScanKind_Name(kind), "SCAN_KIND_"); }

std::string Corners(const google::protobuf::RepeatedPtrField<v1::Point3>& corners) {
    std::vector<std::string> points;
    for (const v1::Point3& p : corners) {
        points.push_back(absl::StrFormat("%.3f,%.3f,%.3f", p.x(), p.y(), p.z()));
    }
    return absl::StrJoin(points, ";");
}

void PrintUnreadable(const google::protobuf::RepeatedPtrField<v1::UnreadableEntry>& entries,
                     std::ostream& out) {
    for (const v1::UnreadableEntry& entry : entries) {
        out << "unreadable: " << entry.id() << ": " << entry.reason() << "\n";
    }
}

std::string Percent(double ratio) { return Fixed(100.0 * ratio, 1); }

/// "corners 1-2: 0.20 m^2, 16.1 L; ...", corners 1-4 as marked (as the warnings name them).
std::string UnseenSides(const v1::Container& c) {
    std::vector<std::string> sides;
    for (const v1::UnseenSide& side : c.unseen_sides()) {
        sides.push_back(absl::StrFormat("corners %d-%d: %.2f m^2, %.1f L", side.from_corner() + 1,
                                        side.to_corner() + 1, side.area_m2(),
                                        1000.0 * side.uncertainty_m3()));
    }
    return sides.empty() ? "none" : absl::StrJoin(sides, "; ");
}

/// One `warning:` line per warning of `c`, led by its id when `with_id`.
void PrintWarnings(const v1::Container& c, bool with_id, std::ostream& out) {
    for (const std::string& warning : c.warnings()) {
        out << "warning: " << (with_id ? c.container_id() + ": " : "") << warning << "\n";
    }
}

/// "at (x, y, z) m, quaternion (w, x, y, z)".
std::string PoseText(const v1::Pose& pose) {
    const v1::Point3& p = pose.position_m();
    const v1::Quaternion& q = pose.orientation();
    return absl::StrFormat("at (%.3f, %.3f, %.3f) m, quaternion (%.4f, %.4f, %.4f, %.4f)", p.x(),
                           p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
}

}  // namespace

std::string TimeText(const google::protobuf::Timestamp& time) {
    if (time.seconds() == 0 && time.nanos() == 0) return "-";
    return google::protobuf::util::TimeUtil::ToString(time);
}

std::string EnumLabel(const std::string& name, const std::string& prefix) {
    std::string label = absl::StartsWith(name, prefix) ? name.substr(prefix.size()) : name;
    return label.empty() ? "-" : absl::AsciiStrToLower(label);
}

void PrintJson(const google::protobuf::Message& message, std::ostream& out) {
    google::protobuf::util::JsonPrintOptions options;
    options.always_print_primitive_fields = true;
    std::string text;
    const auto status = google::protobuf::util::MessageToJsonString(message, &text, options);
    out << (status.ok() ? text : "{}") << "\n";
}

void PrintCalibration(const v1::Calibration& c, bool json, std::ostream& out,
                      const std::vector<std::string>& pair_names) {
    if (json) return PrintJson(c, out);
    Fields fields = {
        {"calibration id", c.calibration_id()},
        {"source", Source(c.source())},
        {"image size [px]", absl::StrCat(c.image_width(), " x ", c.image_height())},
        {"baseline [m]", Fixed(c.baseline_m(), 4)},
        {"focal length [px]", Fixed(c.focal_length_px(), 1)},
    };
    if (c.source() == v1::CALIBRATION_SOURCE_CHESSBOARD) {
        fields.push_back({"rms reprojection [px]", Fixed(c.rms_reprojection_error_px(), 3)});
        fields.push_back({"mean epipolar [px]", Fixed(c.mean_epipolar_error_px(), 3)});
        fields.push_back({"pairs used", absl::StrCat(c.pairs_used())});
        fields.push_back({"pairs skipped", absl::StrCat(c.skipped_pairs_size())});
    }
    fields.push_back({"created", TimeText(c.create_time())});
    PrintFields(fields, out);
    for (const v1::SkippedPair& skipped : c.skipped_pairs()) {
        const auto index = static_cast<size_t>(skipped.index());
        const std::string name =
            index < pair_names.size() ? absl::StrCat(" (", pair_names[index], ")") : "";
        out << "  skipped pair " << skipped.index() << name << ": " << skipped.reason() << "\n";
    }
}

void PrintContainer(const v1::Container& c, bool json, std::ostream& out) {
    if (json) return PrintJson(c, out);
    std::string from = Kind(c.registered_from());
    if (!c.calibration_id().empty())
        absl::StrAppend(&from, " (calibration ", c.calibration_id(), ")");
    if (c.has_mesh() && c.registered_from() != v1::SCAN_KIND_MESH)
        absl::StrAppend(&from, " + mesh");
    std::string labels;
    for (const auto& [key, value] : c.labels()) {
        absl::StrAppend(&labels, labels.empty() ? "" : ", ", key, "=", value);
    }
    std::string targets = "none";
    const v1::LoadTargets& t = c.load_targets();
    if (t.has_volume_m3()) targets = absl::StrCat(Fixed(t.volume_m3(), 3), " m^3");
    if (t.has_payload_kg()) targets = absl::StrCat(Fixed(t.payload_kg(), 0), " kg");
    PrintFields({{"container id", c.container_id()},
                 {"display name", c.display_name()},
                 {"labels", labels},
                 {"material", absl::StrCat(c.material().name(), " ",
                                           Fixed(c.material().density_kg_m3(), 0), " kg/m^3")},
                 {"load target", targets},
                 {"registered from", from},
                 {"struck capacity [m^3]", Fixed(c.struck_capacity_m3(), 4)},
                 {"struck 1-sigma [L]", Fixed(1000.0 * c.struck_capacity_uncertainty_m3(), 1)},
                 {"unseen sides", UnseenSides(c)},
                 {"heaped SAE 1:1 [m^3]", Fixed(c.heaped_capacity_m3(), 4)},
                 {"heaped ISO 2:1 [m^3]", Fixed(c.heaped_capacity_iso_m3(), 4)},
                 {"opening area [m^2]", Fixed(c.opening_area_m2(), 4)},
                 {"depth [m]", Fixed(c.depth_m(), 4)},
                 {"noise sigma [m]", Fixed(c.noise_sigma_m(), 4)},
                 {"opening corners [m]", Corners(c.opening_corners())},
                 {"scan points", absl::StrCat(c.scan_points())},
                 {"alignment points", absl::StrCat(c.alignment_points())},
                 {"max range [m]", c.has_max_range_m() ? Fixed(c.max_range_m(), 2) : "none"},
                 {"created", TimeText(c.create_time())}},
                out);
    PrintWarnings(c, false, out);
}

void PrintEstimate(const v1::EstimateVolumeResponse& e, bool json, std::ostream& out) {
    if (json) return PrintJson(e, out);
    const v1::Alignment& a = e.alignment();
    const v1::CellCounts& cells = e.cells();
    const v1::Timings& t = e.timings();
    std::string timings = absl::StrFormat("decode %.1f, ", t.decode_ms());
    if (t.rectify_ms() + t.match_ms() + t.reproject_ms() > 0.0) {
        absl::StrAppendFormat(&timings, "rectify %.1f, match %.1f, reproject %.1f, ",
                              t.rectify_ms(), t.match_ms(), t.reproject_ms());
    }
    absl::StrAppendFormat(
        &timings, "preprocess %.1f, align %.1f, volume %.1f, queue %.1f, total %.1f",
        t.preprocess_ms(), t.align_ms(), t.volume_ms(), t.queue_ms(), t.total_ms());
    Fields fields = {{"container id", e.container_id()}};
    // The record kept (empty with skip_record or a server that keeps none).
    fields.push_back(
        {"estimate id", e.estimate_id().empty() ? "none (not recorded)" : e.estimate_id()});
    if (!e.request_id().empty()) fields.push_back({"request id", e.request_id()});
    if (!e.load_id().empty()) {
        fields.push_back(
            {"load", absl::StrCat(e.load_id(), " (",
                                  EnumLabel(v1::LoadRole_Name(e.load_role()), "LOAD_ROLE_"), ")")});
    }
    fields.insert(
        fields.end(),
        {{"method", EnumLabel(v1::EstimationMethod_Name(e.method()), "ESTIMATION_METHOD_")},
         {"volume [m^3]", Fixed(e.volume_m3(), 4)},
         {"volume [L]", Fixed(1000.0 * e.volume_m3(), 1)},
         {"uncertainty 1-sigma [L]", Fixed(1000.0 * e.uncertainty_m3(), 1)},
         {"fill of struck [%]", Percent(e.fill_ratio())},
         {"fill of heaped SAE [%]", Percent(e.fill_ratio_heaped())}});
    if (e.has_mass_kg()) fields.push_back({"mass [kg]", Fixed(e.mass_kg(), 1)});
    if (e.has_load()) {
        std::string status =
            absl::StrCat(EnumLabel(v1::LoadStatus_Name(e.load().status()), "LOAD_STATUS_"), " (p ",
                         Fixed(e.load().status_probability(), 2), ")");
        if (e.load().has_target_ratio()) {
            absl::StrAppend(&status, ", ", Fixed(100.0 * e.load().target_ratio(), 1),
                            "% of target");
        }
        fields.push_back({"load status", status});
    }
    fields.insert(
        fields.end(),
        {{"alignment",
          absl::StrFormat("fitness %.3f, rmse %.4f m, %s after %d iterations, %d "
                          "correspondences",
                          a.fitness(), a.rmse_m(), a.converged() ? "converged" : "not converged",
                          a.iterations(), a.correspondences())},
         {"cells", absl::StrFormat("%.3f m: %d total, %d measured, %d interpolated, %d with soil",
                                   cells.cell_m(), cells.total(), cells.measured(),
                                   cells.interpolated(), cells.with_soil())},
         {"points", absl::StrFormat("%d in scan, %d used", e.scan_points(), e.used_points())},
         {"container pose", PoseText(e.container_pose())}});
    if (e.has_depth_pixels()) {
        const v1::DepthPixels& p = e.depth_pixels();
        fields.push_back(
            {"depth pixels",
             absl::StrFormat("%d of %d back-projected; dropped: %d no return, %d low confidence, "
                             "%d out of range, %d no ray, %d flying",
                             p.points(), p.pixels(), p.no_return(), p.low_confidence(),
                             p.out_of_range(), p.no_ray(), p.flying())});
    }
    if (e.has_pose_difference()) {
        const v1::PoseDifference& d = e.pose_difference();
        fields.push_back({"from the given pose",
                          absl::StrFormat("%.3f m, %.2f deg", d.distance_m(), d.rotation_deg())});
    }
    fields.push_back({"timings [ms]", timings});
    PrintFields(fields, out);
}

void PrintCalibrationList(const v1::ListCalibrationsResponse& list, bool json, std::ostream& out) {
    if (json) return PrintJson(list, out);
    Table table({"id", "source", "size [px]", "baseline [m]", "focal [px]", "rms [px]", "pairs",
                 "created"});
    for (const v1::Calibration& c : list.calibrations()) {
        const bool board = c.source() == v1::CALIBRATION_SOURCE_CHESSBOARD;
        table.AddRow({c.calibration_id(), Source(c.source()),
                      absl::StrCat(c.image_width(), "x", c.image_height()),
                      Fixed(c.baseline_m(), 4), Fixed(c.focal_length_px(), 1),
                      board ? Fixed(c.rms_reprojection_error_px(), 3) : "-",
                      board ? absl::StrCat(c.pairs_used()) : "-", TimeText(c.create_time())});
    }
    table.Print(out);
    PrintUnreadable(list.unreadable(), out);
}

void PrintContainerList(const v1::ListContainersResponse& list, bool json, std::ostream& out) {
    if (json) return PrintJson(list, out);
    Table table({"id", "from", "struck [m^3]", "1-sigma [L]", "heaped [m^3]", "area [m^2]",
                 "depth [m]", "points", "calibration", "warnings", "created"});
    for (const v1::Container& c : list.containers()) {
        table.AddRow({c.container_id(), Kind(c.registered_from()), Fixed(c.struck_capacity_m3(), 4),
                      Fixed(1000.0 * c.struck_capacity_uncertainty_m3(), 1),
                      Fixed(c.heaped_capacity_m3(), 4), Fixed(c.opening_area_m2(), 3),
                      Fixed(c.depth_m(), 3), absl::StrCat(c.scan_points()),
                      c.calibration_id().empty() ? "-" : c.calibration_id(),
                      absl::StrCat(c.warnings_size()), TimeText(c.create_time())});
    }
    table.Print(out);
    for (const v1::Container& c : list.containers()) PrintWarnings(c, true, out);
    PrintUnreadable(list.unreadable(), out);
}

namespace {

std::vector<std::string> EstimateCells(const v1::Estimate& e) {
    const v1::EstimateVolumeResponse& r = e.result();
    return {e.estimate_id(),
            e.container_id(),
            TimeText(e.create_time()),
            Fixed(r.volume_m3(), 4),
            Fixed(1000.0 * r.uncertainty_m3(), 1),
            r.has_mass_kg() ? Fixed(r.mass_kg(), 0) : "-",
            EnumLabel(v1::LoadStatus_Name(r.load().status()), "LOAD_STATUS_"),
            e.request_id().empty() ? "-" : e.request_id()};
}

const std::vector<std::string> kEstimateHeaders = {
    "id", "container", "time", "volume [m^3]", "sigma [L]", "mass [kg]", "status", "request"};

}  // namespace

void PrintEstimateList(const std::vector<v1::Estimate>& estimates, bool json, std::ostream& out) {
    if (json) {
        v1::ListEstimatesResponse list;
        for (const v1::Estimate& e : estimates) *list.add_estimates() = e;
        return PrintJson(list, out);
    }
    Table table(kEstimateHeaders);
    for (const v1::Estimate& e : estimates) table.AddRow(EstimateCells(e));
    table.Print(out);
}

void PrintEstimateRecord(const v1::Estimate& estimate, bool json, std::ostream& out) {
    if (json) return PrintJson(estimate, out);
    PrintFields(
        {{"estimate id", estimate.estimate_id()}, {"recorded", TimeText(estimate.create_time())}},
        out);
    PrintEstimate(estimate.result(), false, out);
}

void PrintEstimateLine(const v1::Estimate& estimate, bool json, std::ostream& out) {
    if (json) {
        std::string line;
        if (!google::protobuf::util::MessageToJsonString(estimate, &line).ok()) line = "{}";
        out << line << std::endl;
        return;
    }
    const std::vector<std::string> cells = EstimateCells(estimate);
    std::string line;
    for (std::size_t i = 0; i < cells.size(); ++i) {
        absl::StrAppend(&line, i == 0 ? "" : "  ", kEstimateHeaders[i], " ", cells[i]);
    }
    out << line << std::endl;
}

}  // namespace soilvol::client
