#pragma once
// Configurations shared by doubling_test.cpp and doubling_long_test.cpp (control = doubling).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"

namespace dem::test {

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
// undamped; `seed` draws its radii, masses, offsets and velocities), under doubling with level_max at
// omega_max h = 0.3 (the step of the exact-stepper measure, docs/physics.md 8.6) and level_min 12 levels
// below; or, with `fixed`, under fixed-step Verlet at that same omega_max h = 0.3 (one step per sync
// interval, so for as many steps as the doubling run has sync intervals). Energy = kinetic + elastic.
struct PackingPath {
  PackingRun run;
  std::vector<Real> tenth;  // signed (E - E0) / E0 at the end of each tenth of the run
};

inline PackingPath packing_energy_path(Real tolerance, long intervals, std::uint64_t seed = 20240611,
                                       bool fixed = false) {
  WorldConfig c = packing_config(Method::verlet, seed);
  Real omega_max = 0;
  {
    const World probe(c);
    omega_max = omega_max_bound(probe);
  }
  set_doubling(c, 0.3 / omega_max, -12, 0, tolerance);
  if (fixed) {
    c.integrator.control = Control::fixed;
    c.integrator.level_min = c.integrator.level_max = 0;
  }
  World world(c);
  EXPECT_LT(world.linear_momentum().norm(), 1e-15);
  auto energy = [&world] {
    const Energies e = world.energies();
    return e.kinetic + e.elastic;
  };
  const Real e0 = energy();
  PackingPath path;
  PackingRun& r = path.run;
  r.omega_max_h = 0.3;
  const long tenth = intervals / 10;
  for (long s = 0; s < intervals; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Real change = (energy() - e0) / e0, d = std::abs(change);
    if ((s + 1) % tenth == 0) path.tenth.push_back(change);
    r.max_error = std::max(r.max_error, d);
    if (s < tenth) r.first_mean += d / static_cast<Real>(tenth);
    if (s >= intervals - tenth) r.last_mean += d / static_cast<Real>(tenth);
  }
  return path;
}

// An ensemble of packings that differ only in their random draws. Contact onsets and releases each
// leave a small energy error of random sign, so one run's error wanders; whether it *drifts* shows
// only across runs: a drift moves the ensemble's mean and makes its RMS grow in proportion to time,
// a random walk leaves the mean near zero and the RMS grows as the square root of time, a bounded
// oscillation not at all.
struct PackingEnsemble {
  Real max_error = 0;             // over every run and sync interval: max |E - E0| / E0
  std::vector<Real> rms;          // RMS over the runs of (E - E0) / E0 at the end of each tenth
  Real end_mean = 0;              // mean over the runs of (E - E0) / E0 at the end
  Real end_standard_error = 0;    // its standard error
};

inline PackingEnsemble packing_ensemble(Real tolerance, long intervals, int runs, bool fixed = false) {
  std::vector<PackingPath> paths;
  for (int k = 0; k < runs; ++k) paths.push_back(packing_energy_path(tolerance, intervals, 1000 + k, fixed));
  PackingEnsemble e;
  const std::size_t tenths = paths.front().tenth.size();
  e.rms.assign(tenths, 0);
  for (const PackingPath& p : paths) {
    e.max_error = std::max(e.max_error, p.run.max_error);
    for (std::size_t t = 0; t < tenths; ++t) e.rms[t] += p.tenth[t] * p.tenth[t] / runs;
    e.end_mean += p.tenth.back() / runs;
  }
  Real variance = 0;
  for (const PackingPath& p : paths) variance += (p.tenth.back() - e.end_mean) * (p.tenth.back() - e.end_mean) / (runs - 1);
  e.end_standard_error = std::sqrt(variance / runs);
  for (Real& x : e.rms) x = std::sqrt(x);
  std::printf("packing ensemble (%d runs, %s, %ld sync intervals): max |dE|/E0 %.3e; RMS at each tenth:", runs,
              fixed ? "fixed omega_max h = 0.3" : ("doubling tolerance " + sci(tolerance)).c_str(), intervals, e.max_error);
  for (Real x : e.rms) std::printf(" %.2e", x);
  std::printf("; end mean %.2e +- %.2e\n", e.end_mean, e.end_standard_error);
  return e;
}

}  // namespace dem::test
