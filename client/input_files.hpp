#pragma once

#include <array>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace soilvol::client {

/// The whole content of `path`; InvalidArgument naming the file when it cannot be read.
absl::StatusOr<std::string> ReadFile(const std::string& path);

/// A left/right image pair found on disk.
struct ImagePairFiles {
    std::string left;
    std::string right;
};

/// Pairs left*.{png,jpg,jpeg} with right*.{png,jpg,jpeg} in `dir` by the text after
/// "left"/"right" (left01.jpg + right01.png), sorted by that text. Names without a partner are
/// appended to `unpaired`. InvalidArgument when the folder cannot be listed or holds no pair.
absl::StatusOr<std::vector<ImagePairFiles>> FindChessboardPairs(const std::string& dir,
                                                                std::vector<std::string>* unpaired);

/// Parses `dims`-tuples separated by ';' with comma-separated numbers ("1,2,3;4,5,6").
/// InvalidArgument naming `flag` unless there are exactly `count` finite tuples.
absl::StatusOr<std::vector<std::vector<double>>> ParseTuples(const std::string& text, int dims,
                                                             int count, const std::string& flag);

/// A rigid pose: position and unit quaternion (w first), as "x,y,z;qw,qx,qy,qz" [m], or
/// "x,y,z" for the identity orientation (the order Container.container_pose prints in).
struct PoseValues {
    std::array<double, 3> position_m{};
    std::array<double, 4> quaternion{1.0, 0.0, 0.0, 0.0};
};
/// InvalidArgument naming `flag` for anything else: other counts, non-finite numbers, a
/// quaternion whose norm is not 1 within 1e-3.
absl::StatusOr<PoseValues> ParsePose(const std::string& text, const std::string& flag);

/// Prints `error: <message>` to stderr and returns kExitUsage.
int ReportUsageError(const absl::Status& status);

}  // namespace soilvol::client
