#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "core/common/types.hpp"

namespace soilvol::sim {

/// Containers with exact geometry. Container frame: origin at the centre of the opening,
/// z along the opening normal pointing out of the container (the opening is the z = 0 plane),
/// x along the first opening edge (corner 0 -> corner 1).
enum class ContainerKind {
    kPaperBucket,      ///< the paper's box bucket, inner 2.05 x 0.54 x 0.6 m
    kExcavatorBucket,  ///< excavator bucket, 1.2 x 1.0 m opening, sloped and curved walls
    kTruckBed,         ///< truck bed, inner 4.0 x 2.2 x 0.8 m, with cab in front
};

/// Triangle mesh of a container (inner and outer walls, rim, asymmetric linkage) with its
/// exact inner surface, in the container frame.
struct ContainerGeometry {
    std::string name;
    std::vector<Eigen::Vector3d> vertices;
    std::vector<Eigen::Vector3i> triangles;
    Corners opening_corners;          ///< container frame, z = 0, counter-clockwise seen from +z
    double depth_m = 0.0;             ///< opening plane to the lowest inner point
    double struck_capacity_m3 = 0.0;  ///< exact volume between the inner surface and z = 0
    double opening_length_m = 0.0;    ///< opening extent along x
    double opening_width_m = 0.0;     ///< opening extent along y
    /// Inner surface profile (y, z) from the y = -width/2 edge to the y = +width/2 edge, both at
    /// z = 0; y never decreases (no overhangs). The inner surface is this profile extruded along x.
    std::vector<Eigen::Vector2d> inner_profile_yz;
    /// Height [m] (z, <= 0) of the inner surface at (x, y) inside the opening; 0 outside.
    double InnerSurfaceZ(double x, double y) const;
    ContainerKind kind = ContainerKind::kPaperBucket;
};

/// Builds the exact geometry of one container kind.
ContainerGeometry MakeContainer(ContainerKind kind);

/// "paper bucket 2.05x0.54x0.6 m", ... for reports.
std::string ContainerDescription(ContainerKind kind);

/// Struck capacity plus a heap rising at `heap_slope` (vertical:horizontal) from the opening
/// edges [m^3]: slope 1 for SAE J296, 0.5 for ISO 7546. A negative slope counts as 0.
double HeapedCapacity(const ContainerGeometry& container, double heap_slope);

/// Soil surface: a level `fill_height_m` above the lowest inner point, perturbed by a smooth
/// random field, and capped by a heap envelope rising at `heap_slope` (vertical:horizontal)
/// from the opening edges, so a fill above the depth forms a heap.
struct SoilSpec {
    double fill_height_m = 0.0;         ///< above the lowest inner point; <= 0 = empty container
    double perturbation_m = 0.02;       ///< amplitude of the random surface perturbation
    double perturbation_cell_m = 0.10;  ///< spacing of the random control grid
    double heap_slope = 1.0;            ///< 1:1 heap (SAE J296)
};

/// A time-of-flight sensor looking at the container from `distance_m` at an oblique view.
struct SensorSpec {
    double distance_m = 2.5;              ///< sensor to opening centre
    double elevation_deg = 45.0;          ///< view angle above the opening plane
    double azimuth_deg = 0.0;             ///< counter-clockwise about +z, 0 = looking along +y
    double angular_resolution_deg = 0.5;  ///< ray grid step; <= 0 gives no points
    double range_noise_sigma_m = 0.04;    ///< Gaussian range noise along each ray
    double outlier_fraction = 0.0;        ///< share of returns replaced by a random range
    double max_range_m = 8.0;             ///< returns beyond are dropped
};

/// A sensor placed to see most of `kind`'s inside (range noise and resolution at their
/// defaults): paper bucket 2.5 m at 55 deg elevation, 60 deg azimuth; excavator bucket 2.5 m at
/// 65 deg from behind its curved back; truck bed 5 m at 60 deg (its cab makes it over 5 m long).
SensorSpec ViewpointFor(ContainerKind kind);

/// Random container pose change between scans, drawn uniformly up to these bounds.
struct PoseJitter {
    double max_rotation_deg = 0.0;
    double max_translation_m = 0.0;
};

struct SceneSpec {
    ContainerKind container = ContainerKind::kPaperBucket;
    SoilSpec soil;
    SensorSpec sensor;
    PoseJitter jitter;
    uint64_t soil_seed = 1;  ///< seeds the soil surface
    uint64_t scan_seed = 1;  ///< seeds the pose jitter, range noise and outliers
};

/// One simulated scan with its exact ground truth.
struct Scene {
    Cloud points;                  ///< scan frame (sensor at the origin, z along its axis)
    Pose T_scan_container;         ///< true container pose in the scan frame
    Corners opening_corners_scan;  ///< true opening corners in the scan frame
    double true_volume_m3 = 0.0;   ///< soil volume inside the opening, by integration
    double struck_capacity_m3 = 0.0;
    double heaped_capacity_sae_m3 = 0.0;  ///< struck + 1:1 heap (SAE J296)
    double heaped_capacity_iso_m3 = 0.0;  ///< struck + 2:1 heap (ISO 7546)
};

/// Simulates one scan; deterministic for a given spec.
Scene SimulateScene(const SceneSpec& spec);

/// Exact soil volume [m^3] inside the opening for `soil` in `container` (fine integration).
double TrueSoilVolume(const ContainerGeometry& container, const SoilSpec& soil, uint64_t soil_seed);

}  // namespace soilvol::sim
