// Power draw against mill speed (PHYSICS.md 7), a sweep under the ctest label `long`: power rises
// with speed while the charge cascades and cataracts, peaks short of critical speed, and falls once
// the charge centrifuges (it then rides with the shell and needs little torque).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/mill_monitor.h"
#include "engine/scene_loader.h"
#include "engine/world.h"

namespace dem {
namespace {

std::string sweep_scene(Real critical_fraction) {
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
lifters = 8
lifter_height = 0.012
lifter_width = 0.008
lifter_face_angle = 10
critical_fraction = )" + std::to_string(critical_fraction) + R"(
ramp_time = 0.2
discard_revolutions = 1
charge = { count = 200, size = { radius = 0.004 }, seed = 3 }
[integrator]
dt = 1e-4
)";
}

Real mean_power(Real critical_fraction) {
  const Scene scene = load_scene_text(sweep_scene(critical_fraction), "sweep.toml", ".");
  World world(scene.world);
  MillMonitor monitor(*scene.mill, world);
  const Real period = 2 * pi / scene.mill->speed;
  while (monitor.steady_revolutions() < 3) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    monitor.observe(world);
    if (world.time() > 0.2 + 8 * period) break;
  }
  return monitor.mean_power_draw().value_or(-1);
}

TEST(MillLong, PowerDrawPeaksBelowCriticalSpeedThenFalls) {
  const std::vector<Real> fractions = {0.3, 0.5, 0.7, 0.85, 1.0, 1.2, 1.5};
  std::vector<Real> power;
  for (Real f : fractions) {
    power.push_back(mean_power(f));
    std::printf("critical fraction %.2f: mean power draw %.5g W\n", f, power.back());
  }
  const auto peak = std::max_element(power.begin(), power.end()) - power.begin();
  EXPECT_GE(fractions[peak], 0.7);
  EXPECT_LE(fractions[peak], 1.0);
  for (std::size_t k = 0; k + 1 <= static_cast<std::size_t>(peak); ++k) EXPECT_LT(power[k], power[k + 1]) << "rising below the peak";
  EXPECT_LT(power.back(), 0.5 * power[peak]) << "a centrifuged charge draws little power";
}

}  // namespace
}  // namespace dem
