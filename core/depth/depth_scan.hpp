#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "core/common/image.hpp"
#include "core/common/types.hpp"
#include "core/depth/depth_camera.hpp"
#include "core/depth/flying_pixels.hpp"

namespace soilvol::depth {

struct DepthScanConfig {
    /// With a confidence (or amplitude) image: pixels whose value is below this are dropped.
    double min_confidence = 0.0;
    /// Returns nearer or farther along their ray [m] are dropped.
    double min_range_m = 0.05;
    double max_range_m = 100.0;
    FlyingPixelConfig flying;
    /// Images with a longer side are refused before they are decoded.
    int max_side_px = 8192;
};

/// What became of the pixels.
struct DepthScanCounts {
    std::size_t pixels = 0;
    std::size_t no_return = 0;       ///< 0, NaN or infinite
    std::size_t low_confidence = 0;  ///< below min_confidence
    std::size_t out_of_range = 0;    ///< outside [min_range_m, max_range_m]
    std::size_t no_ray = 0;          ///< where the lens model cannot be inverted
    std::size_t flying = 0;          ///< mixed returns at depth edges (FindFlyingPixels)
};

/// The returns of a depth image in the camera frame (OpenCV's: x right, y down, z forward), the
/// camera at the origin: each point's ray is the line from the origin through it.
struct DepthCloud {
    Cloud points;
    std::vector<std::int32_t> pixel;  ///< v * width + u of each point
    int width = 0;
    int height = 0;
    DepthScanCounts counts;
};

/// Back-projects a decoded depth image (16-bit integers or 32-bit floats, `camera`'s unit) with
/// an optional confidence image of the same size, dropping what `config` drops.
/// InvalidArgument naming the field (after `field`: "scan.depth") for an 8-bit depth image,
/// a confidence image of another size, or a camera that cannot describe the image.
absl::StatusOr<DepthCloud> BackProject(const ScalarImage& depth, const ScalarImage* confidence,
                                       const DepthCamera& camera, const DepthScanConfig& config,
                                       std::string_view field);

/// Decodes the depth image (16-bit PNG/TIFF/PGM or 32-bit float TIFF) and the optional
/// confidence image (empty bytes: none; 8, 16 or 32 bits) within config.max_side_px, then
/// BackProject. The images' headers are read before anything is decoded.
absl::StatusOr<DepthCloud> DecodeDepthScan(std::string_view depth_bytes,
                                           std::string_view confidence_bytes,
                                           const DepthCamera& camera, const DepthScanConfig& config,
                                           std::string_view field);

}  // namespace soilvol::depth
