#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "absl/status/statusor.h"
#include "core/model/container_model.hpp"

namespace soilvol::model {

/// Version of the binary model layout written; versions from kOldestModelCodecVersion up are
/// read (version 2 had no thin-shell walls), others refused.
inline constexpr uint32_t kModelCodecVersion = 3;
inline constexpr uint32_t kOldestModelCodecVersion = 2;

/// The model as bytes: magic "SOILVOLM", version, payload size, payload (little-endian), and a
/// 64-bit FNV-1a checksum of the payload.
std::string EncodeModel(const ContainerModel& model);

/// Decodes EncodeModel's bytes. DataLoss for a bad magic, size or checksum (a damaged file);
/// FailedPrecondition for another version; DataLoss for inconsistent contents (counts beyond
/// the payload, non-finite values, an improper rotation). Never allocates more than the input
/// can hold.
absl::StatusOr<ContainerModel> DecodeModel(std::string_view bytes);

}  // namespace soilvol::model
