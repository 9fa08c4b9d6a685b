#include "core/stereo/chessboard_detector.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/stereo/opencv_image.hpp"

namespace soilvol::stereo::detail {
namespace {

// FAST_CHECK costs 2 ms more on a 640 x 480 board but rejects most board-free images 10-20x
// sooner (0.9 s -> 0.05 s on baboon.jpg); detection runs on a copy at most 1280 px wide, since
// a board-free 1282 x 1110 image still takes 3 s.
constexpr int kDetectFlags =
    cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
constexpr int kMaxDetectionSidePx = 1280;
// Sub-pixel half-window: 0.3 of the smallest corner spacing, so that the window never reaches
// the neighbouring corners, within [2, 11] (11 is OpenCV's sample's fixed value).
constexpr double kHalfWindowPerSpacing = 0.3;
constexpr int kMinHalfWindow = 2;
constexpr int kMaxHalfWindow = 11;
// How often a search on its own thread looks at the stop token.
constexpr std::chrono::milliseconds kStopPoll(20);

std::string SizeText(const cv::Size& size) { return absl::StrCat(size.width, "x", size.height); }

// Smallest distance between neighbouring corners of a row or a column [px].
double SmallestSpacing(const std::vector<cv::Point2f>& corners, cv::Size pattern) {
    double spacing = std::numeric_limits<double>::infinity();
    for (int r = 0; r < pattern.height; ++r) {
        for (int c = 0; c < pattern.width; ++c) {
            const cv::Point2f& corner = corners[r * pattern.width + c];
            if (c + 1 < pattern.width) {
                spacing = std::min(spacing, cv::norm(corners[r * pattern.width + c + 1] - corner));
            }
            if (r + 1 < pattern.height) {
                spacing =
                    std::min(spacing, cv::norm(corners[(r + 1) * pattern.width + c] - corner));
            }
        }
    }
    return spacing;
}

// `corners` with the board turned by `quarter_turns` x 90 degrees (odd turns: square boards).
std::vector<cv::Point2f> Turned(const std::vector<cv::Point2f>& corners, cv::Size pattern,
                                int quarter_turns) {
    const int cols = pattern.width;
    const int rows = pattern.height;
    std::vector<cv::Point2f> turned(corners.size());
    for (int r = 0; r < rows; ++r) {
        for (int c = 0; c < cols; ++c) {
            const int from[4][2] = {
                {r, c}, {c, cols - 1 - r}, {rows - 1 - r, cols - 1 - c}, {rows - 1 - c, r}};
            turned[r * cols + c] = corners[from[quarter_turns][0] * cols + from[quarter_turns][1]];
        }
    }
    return turned;
}

// How well the board's row and column directions agree between two corner lists, in [-2, 2].
double DirectionAgreement(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                          cv::Size pattern) {
    const auto unit = [](cv::Point2f v) { return cv::Point2d(v) / std::max(cv::norm(v), 1e-9); };
    const int last_in_row = pattern.width - 1;
    const int first_of_last_row = (pattern.height - 1) * pattern.width;
    return unit(a[last_in_row] - a[0]).ddot(unit(b[last_in_row] - b[0])) +
           unit(a[first_of_last_row] - a[0]).ddot(unit(b[first_of_last_row] - b[0]));
}

// The detector may number a board from either end (any corner for a square board); a rig sees
// the board turned alike in both images, so the right list follows the left one's directions.
void MatchOrder(const std::vector<cv::Point2f>& left, cv::Size pattern,
                std::vector<cv::Point2f>* right) {
    const int step = pattern.width == pattern.height ? 1 : 2;
    std::vector<cv::Point2f> best = *right;
    double best_score = DirectionAgreement(left, best, pattern);
    for (int turns = step; turns < 4; turns += step) {
        std::vector<cv::Point2f> candidate = Turned(*right, pattern, turns);
        const double score = DirectionAgreement(left, candidate, pattern);
        if (score > best_score) {
            best_score = score;
            best = std::move(candidate);
        }
    }
    *right = std::move(best);
}

// Searches left to finish alone after their caller stopped, process-wide. Each may run for up
// to ~20 s on a hostile image: past this many, a stopped call waits for its search instead,
// so that cancelling calls can never pile up threads.
constexpr int kMaxAbandonedSearches = 2;
std::atomic<int> g_abandoned{0};

// One board search on a thread of its own, so that a stop ends the wait at once; the thread
// shares only this state and its own reference to the image, and finishes alone after a stop.
struct Search {
    std::mutex mutex;
    std::condition_variable finished;
    bool done = false;
    bool abandoned = false;
    std::optional<std::vector<cv::Point2f>> corners;
    std::exception_ptr error;
};

// Leaves `search` to finish alone when the budget allows; false when the caller must wait.
bool Abandon(Search& search) {
    int now = g_abandoned.load();
    do {
        if (now >= kMaxAbandonedSearches) return false;
    } while (!g_abandoned.compare_exchange_weak(now, now + 1));
    search.abandoned = true;
    return true;
}

absl::StatusOr<std::optional<std::vector<cv::Point2f>>> DetectUnlessStopped(
    const cv::Mat& grey, cv::Size pattern, const StopToken& stop, std::string_view stage) {
    if (!stop.CanStop()) return DetectChessboard(grey, pattern);
    SOILVOL_RETURN_IF_ERROR(stop.Check(stage));
    auto search = std::make_shared<Search>();
    const auto run = [search, grey, pattern] {
        std::optional<std::vector<cv::Point2f>> corners;
        std::exception_ptr error;
        try {
            corners = DetectChessboard(grey, pattern);
        } catch (...) {
            error = std::current_exception();
        }
        const std::lock_guard<std::mutex> lock(search->mutex);
        search->corners = std::move(corners);
        search->error = error;
        search->done = true;
        if (search->abandoned) --g_abandoned;
        search->finished.notify_all();
    };
    try {
        std::thread(run).detach();
    } catch (const std::system_error&) {
        return DetectChessboard(grey, pattern);  // no thread to spare: search here, unstoppable
    }
    std::unique_lock<std::mutex> lock(search->mutex);
    while (!search->finished.wait_for(lock, kStopPoll, [&] { return search->done; })) {
        if (stop.StopRequested() && Abandon(*search)) return stop.Check(stage);
    }
    SOILVOL_RETURN_IF_ERROR(stop.Check(stage));
    if (search->error) std::rethrow_exception(search->error);
    return std::move(search->corners);
}

// Decodes and detects one pair; a non-OK status carries the reason it is skipped, and
// *too_large says whether that reason fails the whole calibration instead. After a stop the
// status means nothing.
absl::Status DetectPair(const ImagePair& pair, cv::Size pattern, int max_side_px,
                        const StopToken& stop, std::string_view stage, BoardViews* views,
                        bool* too_large) {
    absl::StatusOr<cv::Mat> left = DecodeGreyMat(pair.left, "left", max_side_px, too_large);
    if (!left.ok()) return left.status();
    absl::StatusOr<cv::Mat> right = DecodeGreyMat(pair.right, "right", max_side_px, too_large);
    if (!right.ok()) return right.status();
    if (left->size() != right->size()) {
        return absl::InvalidArgumentError(absl::StrCat("left is ", SizeText(left->size()),
                                                       " but right is ", SizeText(right->size())));
    }
    if (!views->indices.empty() && left->size() != views->image_size) {
        return absl::InvalidArgumentError(absl::StrCat("size ", SizeText(left->size()),
                                                       " differs from the first usable pair's ",
                                                       SizeText(views->image_size)));
    }
    const std::string board = SizeText(pattern);
    SOILVOL_ASSIGN_OR_RETURN(std::optional<std::vector<cv::Point2f>> left_corners,
                             DetectUnlessStopped(*left, pattern, stop, stage));
    if (!left_corners)
        return absl::NotFoundError(absl::StrCat("left: chessboard ", board, " not found"));
    SOILVOL_ASSIGN_OR_RETURN(std::optional<std::vector<cv::Point2f>> right_corners,
                             DetectUnlessStopped(*right, pattern, stop, stage));
    if (!right_corners)
        return absl::NotFoundError(absl::StrCat("right: chessboard ", board, " not found"));
    MatchOrder(*left_corners, pattern, &*right_corners);
    views->image_size = left->size();
    views->left.push_back(std::move(*left_corners));
    views->right.push_back(std::move(*right_corners));
    return absl::OkStatus();
}

}  // namespace

std::optional<std::vector<cv::Point2f>> DetectChessboard(const cv::Mat& grey, cv::Size pattern) {
    std::vector<cv::Point2f> corners;
    const int side = std::max(grey.cols, grey.rows);
    if (side <= kMaxDetectionSidePx) {
        if (!cv::findChessboardCorners(grey, pattern, corners, kDetectFlags)) return std::nullopt;
    } else {
        const double scale = static_cast<double>(kMaxDetectionSidePx) / side;
        cv::Mat smaller;
        cv::resize(grey, smaller, cv::Size(), scale, scale, cv::INTER_AREA);
        if (!cv::findChessboardCorners(smaller, pattern, corners, kDetectFlags)) {
            return std::nullopt;
        }
        // Pixel centres: x_full + 0.5 = (x_small + 0.5) / scale.
        const auto inverse = static_cast<float>(1.0 / scale);
        for (cv::Point2f& corner : corners) {
            corner = (corner + cv::Point2f(0.5f, 0.5f)) * inverse - cv::Point2f(0.5f, 0.5f);
        }
    }
    const int half_window = static_cast<int>(
        std::clamp(kHalfWindowPerSpacing * SmallestSpacing(corners, pattern),
                   static_cast<double>(kMinHalfWindow), static_cast<double>(kMaxHalfWindow)));
    cv::cornerSubPix(grey, corners, cv::Size(half_window, half_window), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 30, 0.01));
    return corners;
}

absl::StatusOr<BoardViews> DetectBoards(const std::vector<ImagePair>& pairs,
                                        const ChessboardSpec& board, int max_side_px,
                                        const StopToken& stop) {
    BoardViews views;
    const cv::Size pattern(board.cols, board.rows);
    for (std::size_t index = 0; index < pairs.size(); ++index) {
        const std::string stage =
            absl::StrCat("chessboard detection (pair ", index + 1, " of ", pairs.size(), ")");
        SOILVOL_RETURN_IF_ERROR(stop.Check(stage));
        bool too_large = false;
        const absl::Status status =
            DetectPair(pairs[index], pattern, max_side_px, stop, stage, &views, &too_large);
        // A search cut short by a stop is no reason to skip the pair (a stop stays a stop).
        SOILVOL_RETURN_IF_ERROR(stop.Check(stage));
        if (too_large) {
            return absl::InvalidArgumentError(absl::StrCat("pair ", index, ": ", status.message()));
        }
        if (status.ok()) {
            views.indices.push_back(static_cast<int>(index));
        } else {
            views.skipped.push_back({static_cast<int>(index), std::string(status.message())});
        }
    }
    return views;
}

}  // namespace soilvol::stereo::detail

namespace soilvol::stereo {

int AbandonedBoardSearches() { return detail::g_abandoned.load(); }

}  // namespace soilvol::stereo
