#pragma once

// Private to core/stereo (.cpp files only): chessboard corners in stereo pairs.

#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/stop_token.hpp"
#include "core/stereo/calibration.hpp"

namespace soilvol::stereo::detail {

/// Inner corners of a cols x rows board in `grey` (CV_8UC1), row by row, refined to
/// sub-pixel; nullopt when the board is not found.
std::optional<std::vector<cv::Point2f>> DetectChessboard(const cv::Mat& grey, cv::Size pattern);

/// Corners of every usable pair, in input order, with the reasons for the others.
struct BoardViews {
    cv::Size image_size;       ///< of the first usable pair; all usable pairs share it
    std::vector<int> indices;  ///< input position of each usable pair
    std::vector<std::vector<cv::Point2f>> left;
    std::vector<std::vector<cv::Point2f>> right;  ///< ordered like `left` (same board corner)
    std::vector<SkippedPair> skipped;
};

/// Decodes each pair and finds the board in both images. InvalidArgument naming the pair for
/// an image with a side longer than max_side_px. `stop` is checked before each image and while
/// its board is sought: one search can take seconds (15-23 s on a 1280 x 960 image of small
/// squares that is no 9 x 6 board), so with a stoppable token it runs on a thread of its own,
/// which a stop leaves to finish alone with its own reference to the image.
absl::StatusOr<BoardViews> DetectBoards(const std::vector<ImagePair>& pairs,
                                        const ChessboardSpec& board, int max_side_px,
                                        const StopToken& stop = {});

}  // namespace soilvol::stereo::detail
