#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/sim/mesh_builder.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::sim {

/// Points (y, z) of an inner profile, from the -y opening edge to the +y edge, both at z = 0.
using Profile = std::vector<Eigen::Vector2d>;

/// A container shell: an inner profile extruded along x between vertical end plates, walls of
/// one thickness and a flat rim around the opening.
struct ShellSpec {
    double length_m = 0.0;  ///< opening along x
    Profile profile;
    double wall_m = 0.025;
    double rim_width_m = 0.06;
    double rim_thickness_m = 0.03;
};

/// Box of `width_m` x `depth_m`.
Profile BoxProfile(double width_m, double depth_m);
/// Flat floor between a front wall (-y) and a back wall (+y) at the given angles from the
/// opening plane [deg]; the floor keeps at least 10% of the width.
Profile SlopedProfile(double width_m, double depth_m, double front_deg, double back_deg);
/// Sloped front wall, flat floor, back wall as an elliptic quarter arc in `arc_segments` chords
/// (vertical at the rim, horizontal at the floor).
Profile ExcavatorProfile(double width_m, double depth_m, double floor_m, double front_run_m,
                         int arc_segments);
/// Outward unit normal (away from the cavity) of the profile segment a -> b.
Eigen::Vector2d OutwardNormal(const Eigen::Vector2d& a, const Eigen::Vector2d& b);

/// Adds walls, floor, end plates and rim of `shell` to `mesh`.
void AddShell(const ShellSpec& shell, MeshBuilder* mesh);
/// Sets the opening, profile, depth and exact struck capacity of `container` from `shell`.
void SetOpening(const ShellSpec& shell, ContainerGeometry* container);

}  // namespace soilvol::sim
