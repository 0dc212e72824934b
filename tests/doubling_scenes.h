#pragma once
// Configurations shared by doubling_test.cpp and doubling_long_test.cpp (control = doubling).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"

namespace dem::test {

/// Known failures run (and fail) only with DEM_RUN_KNOWN_FAILURES=1; otherwise they are skipped.
inline bool run_known_failures() {
  const char* flag = std::getenv("DEM_RUN_KNOWN_FAILURES");
  return flag != nullptr && std::string(flag) == "1";
}

/// Step doubling with every setting of the error control stated.
inline void set_doubling(WorldConfig& c, Real dt_base, int level_min, int level_max, Real tolerance) {
  c.integrator.control = Control::doubling;
  c.integrator.dt = dt_base;
  c.integrator.dt_base = dt_base;
  c.integrator.level_min = level_min;
  c.integrator.level_max = level_max;
  c.integrator.tolerance = tolerance;
  c.integrator.velocity_weight = 1;
  c.integrator.dx_min = 1e-3;
}

// The packing of contact_scenes.h (36 discs in a box, ~1% overlaps, no gravity, zero total momentum,
// undamped), under doubling with level_max at omega_max h = 0.3 (the step of the exact-stepper
// measure, PHYSICS.md 6.6) and level_min 12 levels below. Energy = kinetic + elastic.
inline PackingRun packing_under_doubling(Real tolerance, long intervals) {
  WorldConfig c = packing_config(Method::verlet);
  Real omega_max = 0;
  {
    const World probe(c);
    omega_max = omega_max_bound(probe);
  }
  set_doubling(c, 0.3 / omega_max, -12, 0, tolerance);
  World world(c);
  EXPECT_LT(world.linear_momentum().norm(), 1e-15);
  auto energy = [&world] {
    const Energies e = world.energies();
    return e.kinetic + e.elastic;
  };
  const Real e0 = energy();
  PackingRun r{};
  r.omega_max_h = 0.3;
  const long tenth = intervals / 10;
  std::printf("packing, tolerance %.0e: (E - E0)/E0 at each tenth:", tolerance);
  for (long s = 0; s < intervals; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Real d = std::abs(energy() - e0) / e0;
    if ((s + 1) % tenth == 0) std::printf(" %.2e", (energy() - e0) / e0);
    r.max_error = std::max(r.max_error, d);
    if (s < tenth) r.first_mean += d / static_cast<Real>(tenth);
    if (s >= intervals - tenth) r.last_mean += d / static_cast<Real>(tenth);
  }
  std::printf("\npacking, tolerance %.0e, %ld sync intervals: max |dE|/E0 %.3e, mean first tenth %.3e, last tenth %.3e\n",
              tolerance, intervals, r.max_error, r.first_mean, r.last_mean);
  return r;
}

}  // namespace dem::test
