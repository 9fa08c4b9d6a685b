#pragma once

#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "google/protobuf/message.h"

namespace soilvol::server {

/// The payload of a store entry: the API message describing it (Calibration or Container, so
/// that get and list need no engine work) and the engine's own bytes (the binary container
/// model; none for a calibration, whose message holds it all). Layout: u32 little-endian info
/// size, info, body.
std::string EncodeStoredRecord(const google::protobuf::Message& info, std::string_view body);

/// Splits a payload written by EncodeStoredRecord. DataLoss when it does not parse; `body`
/// views into `payload`.
absl::Status DecodeStoredRecord(std::string_view payload, google::protobuf::Message* info,
                                std::string_view* body);

}  // namespace soilvol::server
