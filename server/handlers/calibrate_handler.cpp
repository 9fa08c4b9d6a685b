#include <vector>

#include "absl/strings/str_cat.h"
#include "core/common/status_macros.hpp"
#include "core/common/timer.hpp"
#include "google/protobuf/util/time_util.h"
#include "proto/convert/proto_convert.hpp"
#include "server/base/status_map.hpp"
#include "server/handlers/soilvol_handlers.hpp"
#include "server/handlers/stored_record.hpp"

namespace soilvol::server {
namespace {

absl::StatusOr<stereo::StereoCalibration> FromChessboards(const v1::ChessboardCalibration& request,
                                                          const StopToken& stop) {
    SOILVOL_ASSIGN_OR_RETURN(const stereo::ChessboardSpec board, ToChessboardSpec(request));
    std::vector<stereo::ImagePair> pairs;
    pairs.reserve(static_cast<std::size_t>(request.pairs_size()));
    for (int i = 0; i < request.pairs_size(); ++i) {
        const v1::ImagePair& pair = request.pairs(i);
        if (pair.left().empty() || pair.right().empty()) {
            return absl::InvalidArgumentError(
                absl::StrCat("chessboard.pairs[", i, "]: needs both left and right images"));
        }
        pairs.push_back({pair.left(), pair.right()});
    }
    absl::StatusOr<stereo::StereoCalibration> calibration =
        stereo::CalibrateFromChessboards(pairs, board, {}, stop);
    if (!calibration.ok()) return Annotate(calibration.status(), "chessboard");
    return calibration;
}

}  // namespace

absl::Status SoilVolumeHandlers::Calibrate(const v1::CalibrateRequest& request,
                                           v1::Calibration* response, CallRecord& record) {
    const Create create{EntryKind::kCalibration, request.calibration_id(), "calibration_id",
                        request.overwrite(),     request.etag(),           request.request_id()};
    bool replayed = false;
    SOILVOL_ASSIGN_OR_RETURN(const std::string id, ClaimId(create, response, &replayed));
    record.ids.push_back({"calibration", id});
    if (replayed) return absl::OkStatus();
    Timer timer;
    absl::StatusOr<stereo::StereoCalibration> calibration;
    switch (request.method_case()) {
        case v1::CalibrateRequest::kChessboard:
            calibration = FromChessboards(request.chessboard(), record.stop);
            break;
        case v1::CalibrateRequest::kParameters: {
            SOILVOL_ASSIGN_OR_RETURN(const StereoParameters parameters,
                                     ToStereoParameters(request.parameters(), "parameters"));
            calibration = stereo::CalibrationFromParameters(parameters);
            if (!calibration.ok()) return Annotate(calibration.status(), "parameters");
            break;
        }
        default:
            return absl::InvalidArgumentError(
                "method: give chessboard {pairs, inner_corners, square_size_m} or parameters");
    }
    if (!calibration.ok()) return calibration.status();
    record.stages_ms.push_back({"calibrate", timer.Lap()});

    ToProto(*calibration, response);
    response->set_calibration_id(id);
    *response->mutable_create_time() = NowTimestamp();
    SOILVOL_RETURN_IF_ERROR(record.stop.Check("calibration, before storing it"));
    // The message is the whole record: ToStereoCalibration rebuilds the rig from it.
    return Store(create, id, response, {});
}

}  // namespace soilvol::server
