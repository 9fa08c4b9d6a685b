#pragma once

// Private to core/io: collects decoded points, dropping and counting non-finite ones.

#include <cmath>
#include <cstddef>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "core/io/cloud_codec.hpp"

namespace soilvol::io::detail {

/// Receives every decoded point; `expected_points` must already be checked against the input.
class PointSink {
  public:
    PointSink(CloudFormat format, std::size_t expected_points) {
        cloud_.format = format;
        cloud_.points.reserve(expected_points);
    }

    void Add(float x, float y, float z) {
        if (std::isfinite(x) && std::isfinite(y) && std::isfinite(z)) {
            cloud_.points.emplace_back(x, y, z);
        } else {
            ++cloud_.dropped_nonfinite;
        }
    }

    /// The cloud, or InvalidArgument when no finite point was added.
    absl::StatusOr<DecodedCloud> Finish() && {
        if (!cloud_.points.empty()) return std::move(cloud_);
        if (cloud_.dropped_nonfinite == 0) return absl::InvalidArgumentError("cloud has no points");
        return absl::InvalidArgumentError(
            absl::StrCat("no finite points (", cloud_.dropped_nonfinite, " dropped as NaN/Inf)"));
    }

  private:
    DecodedCloud cloud_;
};

}  // namespace soilvol::io::detail
