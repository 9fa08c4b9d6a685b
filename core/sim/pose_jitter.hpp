#pragma once

#include <random>

#include "core/common/types.hpp"
#include "core/sim/scene.hpp"

namespace soilvol::sim {

/// Random container pose change drawn from `rng`: a rotation about a uniform random axis through
/// the container origin by an angle uniform in [0, max_rotation_deg], then a translation uniform
/// in the ball of radius max_translation_m. Negative bounds count as 0 (the draws still happen,
/// so later draws from `rng` do not depend on the bounds).
Pose JitterPose(const PoseJitter& jitter, std::mt19937_64* rng);

}  // namespace soilvol::sim
