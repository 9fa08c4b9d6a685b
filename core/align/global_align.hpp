#pragma once

#include <optional>

#include "core/common/stop_token.hpp"
#include "core/common/types.hpp"

namespace soilvol::align {

/// Coarse global alignment for container moves beyond ICP's reach (tens of degrees, a metre):
/// FPFH descriptors of both clouds' local shape, matched by RANSAC over triples of
/// correspondences with pre-rejection of triples whose edge lengths disagree (PCL's
/// SampleConsensusPrerejective). Both clouds are voxel-averaged at `voxel_m`; normals face each
/// cloud's own sensor, so that the two sides of a thin wall are told apart.
struct GlobalAlignConfig {
    double voxel_m = 0.05;
    double normal_radius_m = 0.12;   ///< at least 2 voxels, and 3 noise sigmas
    double feature_radius_m = 0.30;  ///< a rim corner with its walls
    int max_iterations = 20000;
    double inlier_distance_m = 0.08;    ///< a match is an inlier within this distance
    double min_inlier_fraction = 0.30;  ///< of the source's points, for a pose to be returned
    /// With a reference pose, candidates turned further from it are a symmetric container's
    /// other orientation, not a move: the search runs again, up to `attempts` times.
    double max_turn_deg = 90.0;
    int attempts = 3;
    int num_threads = 0;  ///< 0 = all
};

/// Container pose in the scan frame aligning `source` (container frame, seen from
/// `source_sensor`, container frame) to `scan` (scan frame, sensor at the origin), or nullopt
/// when no pose explains enough of the source (or, given `reference`, none within
/// `max_turn_deg` of it). `stop` is checked between the steps (normals, descriptors, each
/// search; PCL's own cannot be interrupted): a stopped search gives nullopt and its caller checks
/// the token.
std::optional<Pose> GlobalAlign(const Cloud& source, const Eigen::Vector3d& source_sensor,
                                const Cloud& scan, const GlobalAlignConfig& config,
                                const std::optional<Pose>& reference = std::nullopt,
                                const StopToken& stop = {});

}  // namespace soilvol::align
