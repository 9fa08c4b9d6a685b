#pragma once

// Private to core/stereo (.cpp files only): checked reads from OpenCV FileStorage trees.

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace soilvol::stereo::detail {

/// OK when OpenCV's recursive YAML parser can take `yaml` without exhausting the stack: at
/// most 1 MiB, 1024 '[' and '{', and per line 64 columns of indentation and 16 ':' or '- '.
/// InvalidArgument otherwise.
absl::Status CheckYamlBounds(std::string_view yaml);

/// Typed reads of the children of a map node; every error is InvalidArgument naming the key
/// as "<prefix>.<key>" (or "<key>" when prefix is empty).
class FileNodeReader {
  public:
    /// InvalidArgument unless `node` is a map.
    static absl::StatusOr<FileNodeReader> Make(const cv::FileNode& node, std::string prefix);

    absl::StatusOr<cv::FileNode> Child(absl::string_view key) const;
    absl::StatusOr<int> Int(absl::string_view key) const;
    absl::StatusOr<double> Real(absl::string_view key) const;  ///< finite
    absl::StatusOr<std::string> String(absl::string_view key) const;
    /// A sequence of at most max_count finite reals.
    absl::StatusOr<std::vector<double>> Reals(absl::string_view key, std::size_t max_count) const;
    /// An !!opencv-matrix of exactly rows x cols finite doubles (dt: d).
    absl::StatusOr<Eigen::MatrixXd> Matrix(absl::string_view key, int rows, int cols) const;

    std::string Path(absl::string_view key) const;

  private:
    FileNodeReader(const cv::FileNode& node, std::string prefix)
        : node_(node), prefix_(std::move(prefix)) {}

    cv::FileNode node_;
    std::string prefix_;
};

}  // namespace soilvol::stereo::detail
