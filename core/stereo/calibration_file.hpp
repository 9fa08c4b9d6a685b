#pragma once

#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/stereo/calibration.hpp"

namespace soilvol::stereo {

/// Version written into every calibration file; files of other versions are refused.
inline constexpr int kCalibrationFileVersion = 1;

/// The calibration as human-readable OpenCV FileStorage YAML (parameters, rectification,
/// figures, version).
std::string SerializeCalibration(const StereoCalibration& calibration);

/// Parses SerializeCalibration's output. InvalidArgument naming the key for malformed YAML,
/// a missing or mistyped key, an unknown version, or parameters that CalibrationFromParameters
/// refuses; the rectification is recomputed from the parameters and must match the file's.
absl::StatusOr<StereoCalibration> ParseCalibration(std::string_view yaml);

}  // namespace soilvol::stereo
