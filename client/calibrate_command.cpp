#include <google/protobuf/util/json_util.h>

#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "client/commands.hpp"
#include "client/input_files.hpp"
#include "client/response_printer.hpp"

namespace soilvol::client {
namespace {

struct CalibrateOptions {
    std::string id;
    std::string chessboard_dir;
    std::vector<std::string> lefts;
    std::vector<std::string> rights;
    int cols = 0;
    int rows = 0;
    double square_m = 0.0;
    std::string parameters;
    bool overwrite = false;
};

// A StereoParameters document, or a whole Calibration (`calibrations get --json`) whose
// parameters are reused.
absl::StatusOr<v1::StereoParameters> ReadParameters(const std::string& path) {
    absl::StatusOr<std::string> text = ReadFile(path);
    if (!text.ok()) return text.status();
    v1::StereoParameters parameters;
    const auto status = google::protobuf::util::JsonStringToMessage(*text, &parameters);
    if (status.ok()) return parameters;
    v1::Calibration calibration;
    if (google::protobuf::util::JsonStringToMessage(*text, &calibration).ok() &&
        calibration.has_parameters()) {
        return calibration.parameters();
    }
    return absl::InvalidArgumentError(
        absl::StrCat("'", path, "' is not StereoParameters in proto3 JSON: ",
                     absl::StrReplaceAll(status.ToString(), {{"\n", " "}})));
}

absl::StatusOr<std::vector<ImagePairFiles>> PairFiles(const CalibrateOptions& options) {
    if (!options.chessboard_dir.empty()) {
        std::vector<std::string> unpaired;
        auto pairs = FindChessboardPairs(options.chessboard_dir, &unpaired);
        for (const std::string& name : unpaired) {
            std::cerr << "warning: " << name << " has no partner image, ignored\n";
        }
        return pairs;
    }
    if (options.lefts.empty() || options.lefts.size() != options.rights.size()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "calibrate needs --chessboard-dir DIR, as many --left as --right images (got ",
            options.lefts.size(), " and ", options.rights.size(), "), or --parameters FILE"));
    }
    std::vector<ImagePairFiles> pairs;
    for (size_t i = 0; i < options.lefts.size(); ++i) {
        pairs.push_back({options.lefts[i], options.rights[i]});
    }
    return pairs;
}

// Fills request->chessboard from the image files; names each pair for the report.
absl::Status AddChessboard(const CalibrateOptions& options, v1::CalibrateRequest* request,
                           std::vector<std::string>* names) {
    if (options.cols <= 0 || options.rows <= 0 || options.square_m <= 0.0) {
        return absl::InvalidArgumentError(
            "chessboard calibration needs --cols, --rows (inner corners) and --square-m");
    }
    absl::StatusOr<std::vector<ImagePairFiles>> files = PairFiles(options);
    if (!files.ok()) return files.status();
    v1::ChessboardCalibration* board = request->mutable_chessboard();
    board->mutable_inner_corners()->set_cols(options.cols);
    board->mutable_inner_corners()->set_rows(options.rows);
    board->set_square_size_m(options.square_m);
    for (const ImagePairFiles& pair : *files) {
        absl::StatusOr<std::string> left = ReadFile(pair.left);
        if (!left.ok()) return left.status();
        absl::StatusOr<std::string> right = ReadFile(pair.right);
        if (!right.ok()) return right.status();
        v1::ImagePair* images = board->add_pairs();
        images->set_left(*std::move(left));
        images->set_right(*std::move(right));
        names->push_back(std::filesystem::path(pair.left).filename().string() + " + " +
                         std::filesystem::path(pair.right).filename().string());
    }
    return absl::OkStatus();
}

int RunCalibrate(const CalibrateOptions& options, const GlobalOptions& global) {
    v1::CalibrateRequest request;
    request.set_calibration_id(options.id);
    request.set_overwrite(options.overwrite);
    std::vector<std::string> names;
    if (!options.parameters.empty()) {
        absl::StatusOr<v1::StereoParameters> parameters = ReadParameters(options.parameters);
        if (!parameters.ok()) return ReportUsageError(parameters.status());
        *request.mutable_parameters() = *std::move(parameters);
    } else if (absl::Status status = AddChessboard(options, &request, &names); !status.ok()) {
        return ReportUsageError(status);
    }
    Connection connection(global);
    if (!connection.ok()) return kExitUsage;
    v1::Calibration calibration;
    const auto context = connection.NewContext();
    const grpc::Status status = connection.Soil().Calibrate(context.get(), request, &calibration);
    if (!status.ok()) return ReportRpcError(status);
    PrintCalibration(calibration, global.json, std::cout, names);
    return kExitOk;
}

}  // namespace

void AddCalibrateCommand(CLI::App& app, const GlobalOptions& global, int* exit_code) {
    auto options = std::make_shared<CalibrateOptions>();
    auto* command = app.add_subcommand(
        "calibrate", "calibrate a stereo rig from chessboard pairs or known parameters");
    command->add_option("--id", options->id, "calibration id (the server picks one if omitted)");
    auto* dir = command->add_option("--chessboard-dir", options->chessboard_dir,
                                    "folder of left*.png|jpg / right*.png|jpg chessboard pairs");
    auto* left = command->add_option("--left", options->lefts, "left chessboard image (repeat)");
    auto* right =
        command->add_option("--right", options->rights, "right chessboard image (repeat)");
    auto* cols = command->add_option("--cols", options->cols, "inner corners per board row")
                     ->check(CLI::Range(2, 100));
    auto* rows = command->add_option("--rows", options->rows, "inner corners per board column")
                     ->check(CLI::Range(2, 100));
    auto* square = command->add_option("--square-m", options->square_m, "square side [m]")
                       ->check(CLI::PositiveNumber);
    auto* parameters =
        command->add_option("--parameters", options->parameters,
                            "StereoParameters as proto3 JSON (or a Calibration's JSON)");
    command->add_flag("--overwrite", options->overwrite, "replace a calibration with this id");
    dir->excludes(left)->excludes(right);
    for (auto* board_option : {dir, left, right, cols, rows, square}) {
        parameters->excludes(board_option);
    }
    command->callback(
        [options, &global, exit_code] { *exit_code = RunCalibrate(*options, global); });
}

}  // namespace soilvol::client
