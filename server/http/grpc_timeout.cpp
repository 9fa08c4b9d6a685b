#include "server/http/grpc_timeout.hpp"

#include <algorithm>
#include <cctype>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace soilvol::server {

absl::StatusOr<double> ParseGrpcTimeout(const std::string& value) {
    if (value.size() < 2 || value.size() > 9) {
        return absl::InvalidArgumentError(
            absl::StrCat("Grpc-Timeout: '", value, "' is not 1-8 digits and a unit"));
    }
    long long amount = 0;
    const std::string digits = value.substr(0, value.size() - 1);
    if (!std::all_of(digits.begin(), digits.end(), ::isdigit) ||
        !absl::SimpleAtoi(digits, &amount)) {
        return absl::InvalidArgumentError(
            absl::StrCat("Grpc-Timeout: '", value, "' does not start with digits"));
    }
    const auto amount_d = static_cast<double>(amount);
    double ms = 0.0;
    switch (value.back()) {
        case 'H':
            ms = amount_d * 3600e3;
            break;
        case 'M':
            ms = amount_d * 60e3;
            break;
        case 'S':
            ms = amount_d * 1e3;
            break;
        case 'm':
            ms = amount_d;
            break;
        case 'u':
            ms = amount_d * 1e-3;
            break;
        case 'n':
            ms = amount_d * 1e-6;
            break;
        default:
            return absl::InvalidArgumentError(absl::StrCat("Grpc-Timeout: unit '",
                                                           std::string(1, value.back()),
                                                           "' is not one of H, M, S, m, u, n"));
    }
    // A clock of nanoseconds overflows past 292 years; no call needs more than a day.
    constexpr double kDayMs = 86400e3;
    return std::min(ms, kDayMs);
}

}  // namespace soilvol::server
