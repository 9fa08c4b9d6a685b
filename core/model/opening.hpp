#pragma once

#include <array>

#include "absl/status/statusor.h"
#include "core/common/polygon.hpp"
#include "core/common/types.hpp"

namespace soilvol::model {

struct OpeningConfig {
    double min_edge_m = 0.05;  ///< shorter opening edges are a marking mistake
    /// The containers served: excavator and loader buckets (0.3-6 m), truck bodies and bins (up
    /// to about 12 m), rail wagons (up to 25 m). Larger openings are refused before anything is
    /// allocated for them.
    double max_edge_m = 30.0;
    double max_area_m2 = 400.0;
    double max_nonplanarity = 0.15;       ///< corner offset from their plane / shortest edge
    double min_corner_area_ratio = 0.02;  ///< each corner triangle vs the opening area
};

/// The opening of a container and the container frame it defines: origin at the opening's
/// centroid, z along the opening normal pointing out of the container, x along corner 0 -> 1.
struct Opening {
    Pose T_scan_container = Pose::Identity();  ///< container frame in the scan frame
    Polygon2d polygon;                         ///< corners in the container frame (z = 0)
    double nonplanarity_m = 0.0;               ///< largest corner offset from the fitted plane
    /// The marked corner (0-3, in the order given) each polygon vertex is: the polygon runs
    /// counter-clockwise, so a clockwise marking is stored reversed.
    std::array<int, 4> corner_of_vertex{0, 1, 2, 3};
    double area_m2 = 0.0;
};

/// Builds the opening from 4 corners (scan frame, ordered around the opening) and the empty
/// scan, whose points over the opening decide which side is the inside. InvalidArgument for
/// non-finite, coincident, collinear, self-intersecting or far-from-planar corners, and when
/// no scan point lies over the opening.
absl::StatusOr<Opening> MakeOpening(const Corners& corners_scan, const Cloud& empty_scan,
                                    const OpeningConfig& config);

/// Whether the ray from `sensor` to `p` (container frame) reached p through the opening: a
/// return below the opening plane is inside the container only if its ray crossed that plane
/// within the opening polygon. One that did not came through a wall: the outside of a wall that
/// leans over the opening (a body or bucket narrowing towards its floor), seen from outside.
/// Returns above the plane, and rays from a sensor not above it, pass.
bool EntersThroughOpening(const Eigen::Vector3d& sensor, const Eigen::Vector3f& p,
                          const Polygon2d& opening);

/// The points of `points` (container frame, seen from `sensor`) that EntersThroughOpening, in
/// their order (filtered in place: move a cloud in that is not needed after).
Cloud ThroughOpening(Cloud points, const Eigen::Vector3d& sensor, const Polygon2d& opening);

/// `points` mapped from the scan frame into the container frame by `T_scan_container`.
Cloud ToContainerFrame(const Cloud& points, const Pose& T_scan_container);
/// The inverse: container-frame points into the scan frame.
Cloud ToScanFrame(const Cloud& points, const Pose& T_scan_container);

}  // namespace soilvol::model
