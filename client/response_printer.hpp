#pragma once

#include <google/protobuf/message.h>
#include <google/protobuf/timestamp.pb.h>

#include <ostream>
#include <string>
#include <vector>

#include "soilvol/v1/soilvol.pb.h"

namespace soilvol::client {

/// One proto3 JSON document on one line, every field printed (defaults included).
void PrintJson(const google::protobuf::Message& message, std::ostream& out);

/// Human-readable views of responses; with `json` set each prints PrintJson instead.
/// `pair_names` (optional) names the uploaded chessboard pairs by index for skipped pairs.
void PrintCalibration(const v1::Calibration& calibration, bool json, std::ostream& out,
                      const std::vector<std::string>& pair_names = {});
void PrintContainer(const v1::Container& container, bool json, std::ostream& out);
void PrintEstimate(const v1::EstimateVolumeResponse& estimate, bool json, std::ostream& out);
void PrintCalibrationList(const v1::ListCalibrationsResponse& list, bool json, std::ostream& out);
void PrintContainerList(const v1::ListContainersResponse& list, bool json, std::ostream& out);
/// Records: a table of several (newest first), or one in full.
void PrintEstimateList(const std::vector<v1::Estimate>& estimates, bool json, std::ostream& out);
void PrintEstimateRecord(const v1::Estimate& estimate, bool json, std::ostream& out);
/// One line per record as a watch receives it (JSON: one object per line).
void PrintEstimateLine(const v1::Estimate& estimate, bool json, std::ostream& out);

/// RFC 3339 of `time`, "-" when unset.
std::string TimeText(const google::protobuf::Timestamp& time);

/// "CALIBRATION_SOURCE_CHESSBOARD" -> "chessboard": the enum value name without `prefix`.
std::string EnumLabel(const std::string& name, const std::string& prefix);

}  // namespace soilvol::client
