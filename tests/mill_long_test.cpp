// Power draw against mill speed (docs/physics.md 7.2), a sweep under the ctest label `long`: power rises
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
#include "tests/mill_scenes.h"

namespace dem {
namespace {

Real mean_power(Real critical_fraction) {
  const Scene scene = load_scene_text(test::mill_scene(8, critical_fraction, "count = 200", 1), "sweep.toml", ".");
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
