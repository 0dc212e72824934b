// Long validation (ctest label `long`) of the contact physics: the 1e5-period energy-drift run and
// the 1e5-step packing run of docs/physics.md 8.6. Scenes and bounds are shared with
// contact_physics_test.cpp (tests/contact_scenes.h), which runs the 1e4-period / 2e4-step versions.
#include <gtest/gtest.h>

#include <stdexcept>

#include "tests/contact_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

TEST(ContactPhysicsLong, UndampedBouncingParticleShowsNoEnergyDriftOver1e5Periods) {
  const DriftResult r = bounce_between_walls(100'000);
  expect_no_drift(r);
  RecordProperty("max_energy_error", sci(r.max_error));
  RecordProperty("first_tenth_mean", sci(r.first_mean));
  RecordProperty("last_tenth_mean", sci(r.last_mean));
}

TEST(ContactPhysicsLong, VerletKeepsEnergyOfCompressedPackingWithin1e3WithoutTrendOver1e5Steps) {
  // Bounds as in ContactPhysics.VerletKeepsEnergyOfCompressedPackingWithin1e3WithoutTrend.
  const PackingRun r = run_packing(persistent_packing_config(Method::verlet), 0.3, 100'000);
  record(r);
  EXPECT_EQ(r.contact_events, 0u);
  EXPECT_LE(r.max_error, 1e-3);
  EXPECT_LE(r.max_error * r.initial_energy, 1.05 * 0.25 * 0.3 * 0.3 * r.initial_kinetic);
  EXPECT_GE(r.min_change, -1e-12);
  EXPECT_LE(r.last_mean, 1.2 * r.first_mean);
}

TEST(ContactPhysicsLong, VerletEnergyErrorInUndampedPackingIsBoundedWithoutTrendOver1e5Steps) {
  // Bounds as in ContactPhysics.VerletEnergyErrorInUndampedPackingIsBoundedWithoutTrend.
  const PackingRun r = run_packing(Method::verlet, 0.3, 100'000);
  record(r);
  EXPECT_LE(r.max_error, 0.25 * 0.3 * 0.3);
  EXPECT_LE(r.last_mean, 8 * r.first_mean);
}

TEST(ContactPhysicsLong, ExactMethodKeepsPackingEnergyWithin1e3Over1e5Steps) {
  // docs/physics.md 8.6, scheme (D): |dE| <= 1e-3 at omega_max h = 0.3, no trend over 1e5 steps.
  const PackingRun r = run_packing(Method::exact, 0.3, 100'000);
  record(r);
  EXPECT_LE(r.max_error, 1e-3);
  EXPECT_LE(r.last_mean, 8 * r.first_mean);
}

}  // namespace
}  // namespace dem
