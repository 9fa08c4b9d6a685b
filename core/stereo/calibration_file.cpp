#include "core/stereo/calibration_file.hpp"

#include <algorithm>
#include <cmath>
#include <new>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/stereo/file_node_reader.hpp"

namespace soilvol::stereo {
namespace {

using detail::FileNodeReader;

constexpr std::size_t kMaxDistortion = 8;
constexpr std::size_t kMaxListEntries = 1000;     // pairs, skipped
constexpr double kRectificationTolerance = 1e-6;  // relative, per element

void WriteCamera(cv::FileStorage& fs, const char* name, const CameraIntrinsics& camera) {
    fs.startWriteStruct(name, cv::FileNode::MAP);
    fs.write("fx", camera.fx);
    fs.write("fy", camera.fy);
    fs.write("cx", camera.cx);
    fs.write("cy", camera.cy);
    fs.startWriteStruct("distortion", cv::FileNode::SEQ | cv::FileNode::FLOW);
    for (const double coefficient : camera.distortion) fs.write("", coefficient);
    fs.endWriteStruct();
    fs.endWriteStruct();
}

void WriteMatrix(cv::FileStorage& fs, const char* name, const Eigen::MatrixXd& matrix) {
    cv::Mat mat;
    cv::eigen2cv(matrix, mat);
    fs.write(name, mat);
}

std::string Serialize(const StereoCalibration& calibration) {
    cv::FileStorage fs(
        ".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
    const StereoParameters& parameters = calibration.parameters;
    fs.write("version", kCalibrationFileVersion);
    fs.write("source", calibration.source);
    fs.write("image_width", parameters.image_width);
    fs.write("image_height", parameters.image_height);
    WriteCamera(fs, "left", parameters.left);
    WriteCamera(fs, "right", parameters.right);
    WriteMatrix(fs, "R", parameters.R_right_left);
    WriteMatrix(fs, "T", parameters.t_right_left_m);
    fs.write("rms_reprojection_px", calibration.rms_reprojection_px);
    fs.write("mean_epipolar_px", calibration.mean_epipolar_px);
    fs.startWriteStruct("pairs", cv::FileNode::SEQ);
    for (const PairError& pair : calibration.pairs) {
        fs.startWriteStruct("", cv::FileNode::MAP | cv::FileNode::FLOW);
        fs.write("index", pair.index);
        fs.write("rms_px", pair.rms_px);
        fs.write("epipolar_px", pair.epipolar_px);
        fs.endWriteStruct();
    }
    fs.endWriteStruct();
    fs.startWriteStruct("skipped", cv::FileNode::SEQ);
    for (const SkippedPair& pair : calibration.skipped) {
        fs.startWriteStruct("", cv::FileNode::MAP | cv::FileNode::FLOW);
        fs.write("index", pair.index);
        fs.write("reason", pair.reason);
        fs.endWriteStruct();
    }
    fs.endWriteStruct();
    // Derived values last: a truncated file loses or alters one and fails the consistency check.
    WriteMatrix(fs, "R1", calibration.R1);
    WriteMatrix(fs, "R2", calibration.R2);
    WriteMatrix(fs, "P1", calibration.P1);
    WriteMatrix(fs, "P2", calibration.P2);
    WriteMatrix(fs, "Q", calibration.Q);
    fs.write("baseline_m", calibration.baseline_m);
    fs.write("focal_px", calibration.focal_px);
    return fs.releaseAndGetString();
}

absl::Status ReadCamera(const FileNodeReader& root, const char* name, CameraIntrinsics* camera) {
    SOILVOL_ASSIGN_OR_RETURN(const cv::FileNode node, root.Child(name));
    SOILVOL_ASSIGN_OR_RETURN(const FileNodeReader reader, FileNodeReader::Make(node, name));
    SOILVOL_ASSIGN_OR_RETURN(camera->fx, reader.Real("fx"));
    SOILVOL_ASSIGN_OR_RETURN(camera->fy, reader.Real("fy"));
    SOILVOL_ASSIGN_OR_RETURN(camera->cx, reader.Real("cx"));
    SOILVOL_ASSIGN_OR_RETURN(camera->cy, reader.Real("cy"));
    SOILVOL_ASSIGN_OR_RETURN(camera->distortion, reader.Reals("distortion", kMaxDistortion));
    return absl::OkStatus();
}

absl::StatusOr<double> ReadNonNegative(const FileNodeReader& reader, const char* key) {
    SOILVOL_ASSIGN_OR_RETURN(const double value, reader.Real(key));
    if (value < 0.0) {
        return absl::InvalidArgumentError(absl::StrCat("'", reader.Path(key), "' is negative"));
    }
    return value;
}

// Calls read(entry reader) for every map of the sequence under `key`.
template <typename Read>
absl::Status ReadList(const FileNodeReader& root, const char* key, Read read) {
    SOILVOL_ASSIGN_OR_RETURN(const cv::FileNode list, root.Child(key));
    if (!list.isSeq() || list.size() > kMaxListEntries) {
        return absl::InvalidArgumentError(
            absl::StrCat("'", key, "' must be a list of at most ", kMaxListEntries, " entries"));
    }
    for (std::size_t i = 0; i < list.size(); ++i) {
        SOILVOL_ASSIGN_OR_RETURN(
            const FileNodeReader entry,
            FileNodeReader::Make(list[static_cast<int>(i)], absl::StrCat(key, "[", i, "]")));
        SOILVOL_RETURN_IF_ERROR(read(entry));
    }
    return absl::OkStatus();
}

absl::Status CheckMatches(absl::string_view key, const Eigen::MatrixXd& stored,
                          const Eigen::MatrixXd& computed) {
    for (Eigen::Index i = 0; i < stored.size(); ++i) {
        const double difference = std::abs(stored(i) - computed(i));
        if (difference > kRectificationTolerance * std::max(1.0, std::abs(computed(i)))) {
            return absl::InvalidArgumentError(absl::StrCat(
                "'", key, "' does not match the rectification of the stored parameters (",
                stored(i), " vs ", computed(i), ")"));
        }
    }
    return absl::OkStatus();
}

absl::StatusOr<StereoCalibration> ParseRoot(const cv::FileNode& node) {
    SOILVOL_ASSIGN_OR_RETURN(const FileNodeReader root, FileNodeReader::Make(node, ""));
    SOILVOL_ASSIGN_OR_RETURN(const int version, root.Int("version"));
    if (version != kCalibrationFileVersion) {
        return absl::InvalidArgumentError(absl::StrCat(
            "version ", version, " is not supported (expected ", kCalibrationFileVersion, ")"));
    }
    // Parameters, then the rectification recomputed from them and checked against the file's.
    StereoParameters parameters;
    SOILVOL_ASSIGN_OR_RETURN(parameters.image_width, root.Int("image_width"));
    SOILVOL_ASSIGN_OR_RETURN(parameters.image_height, root.Int("image_height"));
    SOILVOL_RETURN_IF_ERROR(ReadCamera(root, "left", &parameters.left));
    SOILVOL_RETURN_IF_ERROR(ReadCamera(root, "right", &parameters.right));
    SOILVOL_ASSIGN_OR_RETURN(parameters.R_right_left, root.Matrix("R", 3, 3));
    SOILVOL_ASSIGN_OR_RETURN(parameters.t_right_left_m, root.Matrix("T", 3, 1));
    SOILVOL_ASSIGN_OR_RETURN(StereoCalibration calibration, CalibrationFromParameters(parameters));
    const std::pair<const char*, Eigen::MatrixXd> computed[] = {
        {"R1", calibration.R1},
        {"R2", calibration.R2},
        {"P1", calibration.P1},
        {"P2", calibration.P2},
        {"Q", calibration.Q},
        {"baseline_m", Eigen::MatrixXd::Constant(1, 1, calibration.baseline_m)},
        {"focal_px", Eigen::MatrixXd::Constant(1, 1, calibration.focal_px)}};
    for (const auto& [key, matrix] : computed) {
        Eigen::MatrixXd stored;
        if (matrix.size() == 1) {
            SOILVOL_ASSIGN_OR_RETURN(const double value, root.Real(key));
            stored = Eigen::MatrixXd::Constant(1, 1, value);
        } else {
            SOILVOL_ASSIGN_OR_RETURN(stored, root.Matrix(key, static_cast<int>(matrix.rows()),
                                                         static_cast<int>(matrix.cols())));
        }
        SOILVOL_RETURN_IF_ERROR(CheckMatches(key, stored, matrix));
    }
    // The chessboard figures are kept as stored.
    SOILVOL_ASSIGN_OR_RETURN(calibration.source, root.String("source"));
    if (calibration.source != "chessboard" && calibration.source != "parameters") {
        return absl::InvalidArgumentError("'source' must be 'chessboard' or 'parameters'");
    }
    SOILVOL_ASSIGN_OR_RETURN(calibration.rms_reprojection_px,
                             ReadNonNegative(root, "rms_reprojection_px"));
    SOILVOL_ASSIGN_OR_RETURN(calibration.mean_epipolar_px,
                             ReadNonNegative(root, "mean_epipolar_px"));
    SOILVOL_RETURN_IF_ERROR(ReadList(root, "pairs", [&](const FileNodeReader& entry) {
        PairError pair;
        SOILVOL_ASSIGN_OR_RETURN(pair.index, entry.Int("index"));
        SOILVOL_ASSIGN_OR_RETURN(pair.rms_px, ReadNonNegative(entry, "rms_px"));
        SOILVOL_ASSIGN_OR_RETURN(pair.epipolar_px, ReadNonNegative(entry, "epipolar_px"));
        calibration.pairs.push_back(pair);
        return absl::OkStatus();
    }));
    SOILVOL_RETURN_IF_ERROR(ReadList(root, "skipped", [&](const FileNodeReader& entry) {
        SkippedPair pair;
        SOILVOL_ASSIGN_OR_RETURN(pair.index, entry.Int("index"));
        SOILVOL_ASSIGN_OR_RETURN(pair.reason, entry.String("reason"));
        calibration.skipped.push_back(std::move(pair));
        return absl::OkStatus();
    }));
    return calibration;
}

}  // namespace

std::string SerializeCalibration(const StereoCalibration& calibration) {
    try {
        return Serialize(calibration);
    } catch (const std::exception&) {  // cv::Exception, std::bad_alloc
        return {};                     // ParseCalibration refuses an empty file
    }
}

absl::StatusOr<StereoCalibration> ParseCalibration(std::string_view yaml) {
    SOILVOL_RETURN_IF_ERROR(detail::CheckYamlBounds(yaml));
    if (yaml.substr(0, 5) != "%YAML") {
        return absl::InvalidArgumentError("calibration file: not OpenCV YAML (no %YAML header)");
    }
    try {
        const cv::FileStorage fs(std::string(yaml), cv::FileStorage::READ |
                                                        cv::FileStorage::MEMORY |
                                                        cv::FileStorage::FORMAT_YAML);
        if (!fs.isOpened()) return absl::InvalidArgumentError("calibration file: unreadable YAML");
        return ParseRoot(fs.root());
    } catch (const cv::Exception& e) {
        // OpenCV's parser puts "(line): message" in e.func and its own name in e.err.
        return absl::InvalidArgumentError(
            absl::StrCat("calibration file: malformed YAML: ", e.err, " ", e.func));
    } catch (const std::bad_alloc&) {
        return absl::InvalidArgumentError("calibration file: too large to parse (out of memory)");
    } catch (const std::exception& e) {  // OpenCV 4.6's parser throws std::length_error too
        return absl::InvalidArgumentError(
            absl::StrCat("calibration file: malformed YAML: ", e.what()));
    }
}

}  // namespace soilvol::stereo
