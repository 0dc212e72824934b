// The exact stepper (method = "exact", PHYSICS.md 3.3, 3.4) against analytic oracles: free fall at
// any level, the head-on pair of 6.2 at steps from a fraction of the contact to ten contacts long
// (restitution and contact time to 1e-9), an undamped contact conserving energy to round-off at any
// step, momentum to round-off in a packing, and identical results for any thread count.
#include <gtest/gtest.h>

#include <cmath>

#include "engine/damping.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

WorldConfig exact_config(Real dt) {
  WorldConfig c;
  c.threads = 1;
  c.integrator.method = Method::exact;
  c.integrator.dt = dt;
  c.contacts[0].normal_stiffness = 1e5;
  return c;
}

void advance(World& w, long steps) {
  for (long s = 0; s < steps; ++s) ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
}

TEST(ExactStepper, FreeFallIsExactAtEveryLevel) {
  const Vec3 g(0.3, -0.2, -9.81), x0(1, 2, 3), v0(0.5, -1, 4);
  for (int level = -10; level <= 10; ++level) {
    const Real dt = std::ldexp(1e-3, level);
    WorldConfig c = exact_config(dt);
    c.model.gravity = g;
    c.particles = {test::particle(x0, v0, 0.1, 1)};
    World w(c);
    const long steps = 64;
    advance(w, steps);
    const Real t = dt * steps;
    const Vec3 x = x0 + v0 * t + 0.5 * t * t * g, v = v0 + g * t;
    EXPECT_LE((w.state().position[0] - x).norm(), 1e-13 * (1 + x.norm())) << "level " << level;
    EXPECT_LE((w.state().velocity[0] - v).norm(), 1e-13 * (1 + v.norm())) << "level " << level;
  }
}

/// PHYSICS.md 6.2: m = 1 kg each (m* = 0.5), k = 1e5 N/m, zeta = 0.1.
struct HeadOn {
  Real restitution;
  Real contact_time;
};

HeadOn head_on(Separation separation, Real dt, Real zeta) {
  const Real radius = 0.05, gap = 1e-3, v = 0.5;
  WorldConfig c = exact_config(dt);
  c.model.separation = separation;
  c.contacts[0].normal_damping = {DampingKind::damping_ratio, zeta};
  c.particles = {test::particle(Vec3(-radius - 0.5 * gap, 0, 0), Vec3(v, 0, 0), radius, 1),
                 test::particle(Vec3(radius + 0.5 * gap, 0, 0), Vec3(-v, 0, 0), radius, 1)};
  World w(c);
  const Real onset = gap / (2 * v);
  const Real t_c_bound = 10 * 7.1e-3;
  const long steps = static_cast<long>(std::ceil((onset + t_c_bound + 0.02) / dt));
  advance(w, steps);
  const State& s = w.state();
  const Real v_out = s.velocity[1].x() - s.velocity[0].x();  // separation speed
  // After release the pair is in free flight: the gap at the end dates the release exactly. At a
  // force-zero release the residual overlap is -c delta'/k = (c/k) v_out (PHYSICS.md 1.1).
  const Real omega0 = std::sqrt(1e5 / 0.5), c_over_k = 2 * zeta / omega0;
  const Real residual = separation == Separation::force_zero ? c_over_k * v_out : 0.0;
  const Real distance = s.position[1].x() - s.position[0].x();
  const Real release = w.time() - (distance - (2 * radius - residual)) / v_out;
  return {v_out / (2 * v), release - onset};
}

TEST(ExactStepper, HeadOnPairMatchesTheOracleAtAnyStep) {
  const Real omega0 = std::sqrt(1e5 / 0.5);
  for (Separation sep : {Separation::force_zero, Separation::overlap}) {
    const Real zeta = 0.1;
    const Real e = restitution_from_damping_ratio(zeta, sep);
    const Real t_c = dimensionless_contact_time(zeta, sep) / omega0;
    // The 6.2 numbers themselves, as a check of the oracle functions.
    EXPECT_NEAR(e, sep == Separation::force_zero ? 0.74408 : 0.72925, 1e-5);
    EXPECT_NEAR(t_c, sep == Separation::force_zero ? 6.6100e-3 : 7.0602e-3, 1e-7);
    for (Real dt : {1e-3, 3.3e-3, 1e-2, 2.5e-2, 7.06e-2}) {  // up to ten contact times
      SCOPED_TRACE(dt);
      const HeadOn r = head_on(sep, dt, zeta);
      EXPECT_NEAR(r.restitution, e, 1e-9 * e);
      EXPECT_NEAR(r.contact_time, t_c, 1e-9 * t_c);
    }
  }
}

TEST(ExactStepper, UndampedBounceConservesEnergyToRoundOffAtAnyStep) {
  // A ball bouncing on a floor under gravity, no damping: kinetic + potential + elastic constant.
  const Real period = M_PI * std::sqrt(1.0 / 1e5);  // contact time of the wall contact (m* = m)
  for (Real dt : {0.01 * period, 0.3 * period, period, 3.7 * period, 40 * period}) {
    SCOPED_TRACE(dt);
    WorldConfig c = exact_config(dt);
    c.model.gravity = Vec3(0, 0, -9.81);
    WallConfig floor;
    floor.kind = WallKind::plane;
    c.walls = {floor};
    c.particles = {test::particle(Vec3(0.2, -0.1, 0.15), Vec3(0.3, 0.1, -1), 0.1, 1)};
    World w(c);
    const auto energy = [&] {
      const Energies e = w.energies();
      return e.kinetic + e.potential + e.elastic;
    };
    const Real e0 = energy();
    Real worst = 0;
    const long steps = std::max(200L, static_cast<long>(0.5 / dt));
    for (long s = 0; s < steps; ++s) {
      ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
      worst = std::max(worst, std::abs(energy() - e0));
    }
    EXPECT_LE(worst, 1e-11 * e0);
    EXPECT_GT(w.state().position[0].z(), 0.0);
  }
}

TEST(ExactStepper, BallHitByAMovingWallIsExactAtAnyStep) {
  // A floor rising at 1 m/s hits a ball at rest (undamped, no gravity): in the wall's frame the
  // ball comes in at 1 m/s and leaves at 1 m/s, so it flies off at 2 m/s, leaving the wall at
  // t_on + t_c with t_c = pi sqrt(m/k) (wall: m* = m).
  const Real m = 0.01, k = 1e5, r = 0.01, gap = 0.01, t_c = M_PI * std::sqrt(m / k);
  for (Real dt : {1e-5, 1e-4, 1e-3, 4e-3}) {
    SCOPED_TRACE(dt);
    WorldConfig c = exact_config(dt);
    c.contacts[0].normal_stiffness = k;
    WallConfig floor;
    floor.kind = WallKind::plane;
    floor.velocity = Vec3(0, 0, 1);
    c.walls = {floor};
    c.particles = {test::particle(Vec3(0, 0, r + gap), Vec3::Zero(), r, m)};
    World w(c);
    advance(w, static_cast<long>(std::ceil(0.05 / dt)));
    const Real release = gap + t_c;  // the wall moves at 1 m/s: it meets the ball at t = gap
    const Real z = release + r + 2 * (w.time() - release);
    EXPECT_NEAR(w.state().velocity[0].z(), 2.0, 1e-9);
    EXPECT_NEAR(w.state().position[0].z(), z, 1e-9);
  }
}

TEST(ExactStepper, PackingConservesMomentumAndIsThreadIndependent) {
  WorldConfig c = test::falling_box_scene(5, 5, 5, 9);
  c.integrator.method = Method::exact;
  c.contacts[0].sliding_friction = 0;
  c.contacts[0].rolling_friction = 0;
  c.walls.clear();
  c.model.gravity = Vec3::Zero();
  // Squeeze the lattice so many contacts exist from the start.
  for (auto& p : c.particles) p.position *= 0.9;
  c.model.dimension = 3;
  std::uint64_t hash = 0;
  for (int threads : {1, 2}) {
    c.threads = threads;
    World w(c);
    const Vec3 p0 = w.linear_momentum();
    advance(w, 300);
    EXPECT_GT(w.pair_contacts().size(), 0u);
    EXPECT_LE((w.linear_momentum() - p0).norm(), 1e-14 * w.state().size());
    if (threads == 1) {
      hash = w.state_hash();
    } else {
      EXPECT_EQ(w.state_hash(), hash);
    }
  }
}

TEST(ExactStepper, RefusesFrictionForNow) {
  WorldConfig c = exact_config(1e-3);
  c.contacts[0].sliding_friction = 0.5;
  c.particles = {test::particle(Vec3::Zero(), Vec3::Zero(), 0.1, 1)};
  EXPECT_THROW(World w(c), std::invalid_argument);
}

}  // namespace
}  // namespace dem
