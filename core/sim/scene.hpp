#pragma once

#include <cstdint>
#include <optional>
#include <random>
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

/// Families of containers with random dimensions, for benchmarks and tests that must not be
/// tuned to one shape. Walls are given by their angle from the opening plane (90 = vertical).
enum class ContainerFamily {
    kBox,               ///< vertical walls, flat floor (buckets and bins, 0.5-2.5 m)
    kSlopedSymmetric,   ///< front and back walls at one angle, 55-90 deg
    kSlopedAsymmetric,  ///< front and back walls at two different angles, 55-90 deg
    kExcavator,         ///< sloped front, concave back curving from vertical to the floor
    kFlaredBody,        ///< haul body 3-6 m long whose side walls flare outward, with a cab
    kHighSideBin,       ///< box bin whose back wall rises above the opening
};

/// Every family, in report order.
const std::vector<ContainerFamily>& AllFamilies();
std::string FamilyName(ContainerFamily family);

/// A container of a family with its dimensions. The profile (front wall at -y, back wall at +y)
/// is extruded along x between vertical end plates.
struct ContainerShape {
    ContainerFamily family = ContainerFamily::kBox;
    double length_m = 1.5;        ///< opening along x
    double width_m = 0.8;         ///< opening along y
    double depth_m = 0.6;         ///< opening plane to the floor
    double front_wall_deg = 90;   ///< wall at -y, from the opening plane
    double back_wall_deg = 90;    ///< wall at +y (kExcavator: the arc, vertical at the rim)
    double floor_fraction = 0.4;  ///< kExcavator: flat floor as a share of the width
    double wall_m = 0.025;
    double rim_width_m = 0.06;
    double rim_thickness_m = 0.03;
    double high_side_m = 0.0;  ///< kHighSideBin: back wall height above the opening
    bool linkage = true;       ///< lugs and a cylinder (buckets) or a cab (bodies)
};

/// A shape of `family` with dimensions drawn uniformly from the family's ranges (seeded).
ContainerShape RandomShape(ContainerFamily family, uint64_t seed);

/// Exact geometry of a shape.
ContainerGeometry MakeContainer(const ContainerShape& shape);

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
    /// > 0: a spinning lidar's rings, rows of rays this far apart in elevation (cones about
    /// the scan frame's -y axis, its spin axis), angular_resolution_deg apart along each ring.
    double ring_spacing_deg = 0.0;
    double range_noise_sigma_m = 0.04;  ///< Gaussian range noise along each ray
    double outlier_fraction = 0.0;      ///< share of returns replaced by a random range
    double max_range_m = 8.0;           ///< returns beyond are dropped
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
    std::optional<ContainerShape> shape;  ///< when set, used instead of `container`
    SoilSpec soil;
    SensorSpec sensor;
    PoseJitter jitter;
    /// A fixed move of the container (its own frame, applied before the jitter): a bucket
    /// curled, a body turned and shifted between the empty scan and this one.
    Pose move = Pose::Identity();
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

/// A sensor that sees most of `shape`'s inside: 50-65 deg elevation, from the side its walls
/// face (the low side of a high-side bin, behind an excavator's back), at a distance that keeps
/// the whole container in a 60 deg view; angles drawn from `seed`.
SensorSpec ViewpointFor(const ContainerShape& shape, uint64_t seed);

class SoilSurface;

/// A scan's truth without its points: the container placed by `spec` (the sensor's viewpoint,
/// the move, then the jitter drawn from `rng`), its opening corners in the scan frame, the
/// soil's volume and the capacities. SimulateScene and SimulateTofScene cast their rays into
/// it.
Scene PlaceScene(const SceneSpec& spec, const ContainerGeometry& container, const SoilSurface& soil,
                 std::mt19937_64* rng);

/// Simulates one scan; deterministic for a given spec.
Scene SimulateScene(const SceneSpec& spec);

/// A scan several sensors take together (a loading bridge's lidars): the container placed once
/// as SimulateScene places it before `spec.sensor` (the first sensor, whose frame is the scan
/// frame), and seen as well from each of `more`, placed about the container as that spec says
/// (its viewpoint, then the same move and jitter): a rig whose sensors keep their poses
/// relative to each other from scan to scan. Deterministic for given specs.
struct MultiSensorScene {
    Scene scene;                    ///< the first sensor's returns and the truth
    std::vector<SensorCloud> more;  ///< each further sensor's returns, in its own frame
};
MultiSensorScene SimulateMultiSensorScene(const SceneSpec& spec,
                                          const std::vector<SensorSpec>& more);

/// Two sensors on a bridge over `shape`: the seed's viewpoint (ViewpointFor) raised to 60-75 deg
/// elevation and turned to look across the container (azimuth within 20 deg of 0), and its
/// mirror on the far side (azimuth + 180 deg); same range, noise and resolution.
std::vector<SensorSpec> BridgeViewpoints(const ContainerShape& shape, uint64_t seed);

/// Exact soil volume [m^3] inside the opening for `soil` in `container` (fine integration).
double TrueSoilVolume(const ContainerGeometry& container, const SoilSpec& soil, uint64_t soil_seed);

}  // namespace soilvol::sim
