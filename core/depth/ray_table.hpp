#pragma once

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "absl/status/statusor.h"
#include "core/depth/depth_camera.hpp"

namespace soilvol::depth {

/// Per pixel, its ray with the lens distortion removed, as the point (x, y) where the ray meets
/// the plane z = 1 of the camera frame; NaN where the lens model cannot be inverted (the
/// inversion does not reproduce the pixel to 0.01 px: the far corners of a strong fisheye).
class RayTable {
  public:
    RayTable(int width, int height, std::vector<Eigen::Vector2f> rays)
        : width_(width), height_(height), rays_(std::move(rays)) {}

    int width() const { return width_; }
    int height() const { return height_; }
    const Eigen::Vector2f& At(int index) const { return rays_[static_cast<size_t>(index)]; }

  private:
    int width_;
    int height_;
    std::vector<Eigen::Vector2f> rays_;
};

/// The rays of a width x height image from `camera` (already validated). Computed once per
/// camera and size and kept in a small cache shared by all callers (a fleet has few cameras;
/// undistorting every pixel of a 640x480 image takes tens of milliseconds, a lookup none).
absl::StatusOr<std::shared_ptr<const RayTable>> RaysOf(const DepthCamera& camera, int width,
                                                       int height);

}  // namespace soilvol::depth
