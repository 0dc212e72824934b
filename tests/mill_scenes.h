#pragma once
// The small 2D test mill shared by mill_test and mill_long_test.
#include <string>

#include "engine/types.h"

namespace dem::test {

constexpr Real mill_radius = 0.1;
constexpr Real ball_radius = 0.004;

/// A 2D mill of diameter 0.2 m; `charge` is the [mill] charge's count or filling entry; the first
/// `discard_revolutions` after the ramp are left out of the mean power draw.
inline std::string mill_scene(int lifters, Real critical_fraction, const std::string& charge,
                              int discard_revolutions = 0) {
  return R"(
[scene]
dimension = 2
thickness = 0.008
gravity = [0, -9.81, 0]
[[contacts]]
normal_stiffness = 5e3
normal_damping = { restitution = 0.5 }
sliding_friction = 0.4
rolling_friction = 0.02
[mill]
diameter = 0.2
lifters = )" + std::to_string(lifters) + (lifters > 0 ? R"(
lifter_height = 0.012
lifter_width = 0.008
lifter_face_angle = 10)" : "") + R"(
critical_fraction = )" + std::to_string(critical_fraction) +
         R"(
ramp_time = 0.2
discard_revolutions = )" + std::to_string(discard_revolutions) + R"(
charge = { )" + charge + R"(, size = { radius = 0.004 }, seed = 3 }
[integrator]
dt = 1e-4
)";
}

}  // namespace dem::test
