#pragma once

#include <string>

#include "absl/status/statusor.h"

namespace soilvol::server {

/// A Grpc-Timeout header value ("10S", "500m", "2M", "1H", "250u", "100n") in milliseconds;
/// anything beyond a day (up to 99999999H) is read as a day.
absl::StatusOr<double> ParseGrpcTimeout(const std::string& value);

}  // namespace soilvol::server
