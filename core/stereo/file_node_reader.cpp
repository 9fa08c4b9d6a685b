#include "core/stereo/file_node_reader.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "absl/strings/str_cat.h"

namespace soilvol::stereo::detail {
namespace {

// OpenCV 4.6's YAML parser recurses once per nesting level and overflows a 1 MiB stack near
// 5000 levels. Block nesting needs a deeper column per level, flow nesting a bracket each.
constexpr std::size_t kMaxYamlBytes = 1 << 20;
constexpr int kMaxOpenings = 1024;
constexpr std::size_t kMaxIndent = 64;
constexpr int kMaxLineTokens = 16;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

absl::Status Refuse(std::size_t line, absl::string_view problem) {
    return absl::InvalidArgumentError(absl::StrCat("calibration file line ", line, ": ", problem));
}

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

}  // namespace

absl::Status CheckYamlBounds(std::string_view yaml) {
    if (yaml.size() > kMaxYamlBytes) {
        return absl::InvalidArgumentError(
            absl::StrCat("calibration file: ", yaml.size(), " bytes, at most ", kMaxYamlBytes));
    }
    int openings = 0;
    std::size_t line_number = 1;
    for (std::size_t start = 0; start < yaml.size(); ++line_number) {
        std::size_t end = yaml.find_first_of("\r\n", start);
        if (end == std::string_view::npos) end = yaml.size();
        const std::string_view line = yaml.substr(start, end - start);
        const std::size_t indent = line.find_first_not_of(" \t");
        if (indent != std::string_view::npos && indent > kMaxIndent) {
            return Refuse(line_number, "indented too deeply");
        }
        int colons = 0;
        int dashes = 0;
        for (std::size_t i = 0; i < line.size(); ++i) {
            const char c = line[i];
            // The files this reads are written as printable ASCII; OpenCV's parser loops
            // forever on some inputs with a NUL or bytes past ASCII (found by fuzzing).
            const auto u = static_cast<unsigned char>(c);
            if ((u < 0x20 && c != '\t') || u >= 0x7F) {
                return Refuse(line_number, absl::StrCat("byte 0x", absl::Hex(u, absl::kZeroPad2),
                                                        " is not printable ASCII"));
            }
            colons += c == ':';
            dashes += c == '-' && (i + 1 == line.size() || IsBlank(line[i + 1]));
            openings += c == '[' || c == '{';
        }
        if (colons > kMaxLineTokens || dashes > kMaxLineTokens) {
            return Refuse(line_number, "nested too deeply");
        }
        if (openings > kMaxOpenings) return Refuse(line_number, "too many '[' or '{'");
        start = end + 1;
    }
    return absl::OkStatus();
}

absl::StatusOr<FileNodeReader> FileNodeReader::Make(const cv::FileNode& node, std::string prefix) {
    if (!node.isMap()) {
        return absl::InvalidArgumentError(
            absl::StrCat(prefix.empty() ? "the calibration file" : prefix, " must be a map"));
    }
    return FileNodeReader(node, std::move(prefix));
}

std::string FileNodeReader::Path(absl::string_view key) const {
    return prefix_.empty() ? std::string(key) : absl::StrCat(prefix_, ".", key);
}

absl::StatusOr<cv::FileNode> FileNodeReader::Child(absl::string_view key) const {
    cv::FileNode child = node_[std::string(key)];
    if (child.empty()) {
        return absl::InvalidArgumentError(absl::StrCat("missing key '", Path(key), "'"));
    }
    return child;
}

absl::StatusOr<int> FileNodeReader::Int(absl::string_view key) const {
    absl::StatusOr<cv::FileNode> child = Child(key);
    if (!child.ok()) return child.status();
    if (!child->isInt()) {
        return absl::InvalidArgumentError(absl::StrCat("'", Path(key), "' must be an integer"));
    }
    return static_cast<int>(*child);
}

absl::StatusOr<double> FileNodeReader::Real(absl::string_view key) const {
    absl::StatusOr<cv::FileNode> child = Child(key);
    if (!child.ok()) return child.status();
    const double value = child->isInt()    ? static_cast<int>(*child)
                         : child->isReal() ? static_cast<double>(*child)
                                           : kNan;
    if (!std::isfinite(value)) {
        return absl::InvalidArgumentError(
            absl::StrCat("'", Path(key), "' must be a finite number"));
    }
    return value;
}

absl::StatusOr<std::string> FileNodeReader::String(absl::string_view key) const {
    absl::StatusOr<cv::FileNode> child = Child(key);
    if (!child.ok()) return child.status();
    if (!child->isString()) {
        return absl::InvalidArgumentError(absl::StrCat("'", Path(key), "' must be a string"));
    }
    return child->string();
}

absl::StatusOr<std::vector<double>> FileNodeReader::Reals(absl::string_view key,
                                                          std::size_t max_count) const {
    absl::StatusOr<cv::FileNode> child = Child(key);
    if (!child.ok()) return child.status();
    if (!child->isSeq() || child->size() > max_count) {
        return absl::InvalidArgumentError(
            absl::StrCat("'", Path(key), "' must be a list of at most ", max_count, " numbers"));
    }
    std::vector<double> values;
    for (const cv::FileNode& element : *child) {
        const double value = element.isInt()    ? static_cast<int>(element)
                             : element.isReal() ? static_cast<double>(element)
                                                : kNan;
        if (!std::isfinite(value)) {
            return absl::InvalidArgumentError(
                absl::StrCat("'", Path(key), "' must hold finite numbers only"));
        }
        values.push_back(value);
    }
    return values;
}

absl::StatusOr<Eigen::MatrixXd> FileNodeReader::Matrix(absl::string_view key, int rows,
                                                       int cols) const {
    absl::StatusOr<cv::FileNode> child = Child(key);
    if (!child.ok()) return child.status();
    absl::StatusOr<FileNodeReader> matrix = Make(*child, Path(key));
    if (!matrix.ok()) return matrix.status();
    const absl::StatusOr<int> stored_rows = matrix->Int("rows");
    const absl::StatusOr<int> stored_cols = matrix->Int("cols");
    const absl::StatusOr<std::string> type = matrix->String("dt");
    if (!stored_rows.ok() || !stored_cols.ok() || !type.ok() || *stored_rows != rows ||
        *stored_cols != cols || *type != "d") {
        return absl::InvalidArgumentError(
            absl::StrCat("'", Path(key), "' must be a ", rows, "x", cols, " matrix of doubles"));
    }
    const std::size_t count = static_cast<std::size_t>(rows) * cols;
    absl::StatusOr<std::vector<double>> data = matrix->Reals("data", count);
    if (!data.ok()) return data.status();
    if (data->size() != count) {
        return absl::InvalidArgumentError(
            absl::StrCat("'", Path(key), ".data' must hold ", count, " numbers"));
    }
    Eigen::MatrixXd values(rows, cols);
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c)
            values(r, c) = (*data)[static_cast<std::size_t>(r) * cols + c];
    }
    return values;
}

}  // namespace soilvol::stereo::detail
