// The exact stepper (method = "exact", docs/physics.md 5.3, 5.4) against analytic oracles: free fall at
// any level, the head-on pair of 6.2 at steps from a fraction of the contact to ten contacts long
// (restitution and contact time to 1e-9), an undamped contact conserving energy to round-off at any
// step, an oblique collision against the classical scattering integral (second-order convergence,
// energy and angular momentum to round-off), near misses that stay misses at any step, uniform
// circular motion inside a cylinder, walls moving faster than the particles, the work of moving walls
// against the energy they give, momentum to round-off in a packing, and identical results for any
// thread count.
#include <gtest/gtest.h>

#include <cmath>

#include "broadphase/brute_force.h"
#include "engine/damping.h"
#include "engine/exact_stepper.h"
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

/// docs/physics.md 8.2: m = 1 kg each (m* = 0.5), k = 1e5 N/m, zeta = 0.1.
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
  // force-zero release the residual overlap is -c delta'/k = (c/k) v_out (docs/physics.md 2.1).
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

// ---- Oblique collisions ---------------------------------------------------------------------------

/// Deflection of the relative velocity in an undamped collision of two spheres (potential
/// k (reach - r)^2 / 2 inside reach) at impact parameter b and relative speed v: the classical
/// scattering integral chi = pi - 2 b int_{r_min}^inf dr / (r^2 sqrt(G(r))),
/// G(r) = 1 - b^2/r^2 - k (reach - r)^2 / (m* v^2) (Landau & Lifshitz, Mechanics, 18). Outside reach the
/// integral is asin(b / reach); inside, with r = r_min + (reach - r_min) s^2 and G(r) = (r - r_min) H(r),
/// it is the smooth int_0^1 2 b sqrt(reach - r_min) / (r^2 sqrt(H)) ds, taken by Simpson's rule.
Real scattering_angle(Real k, Real m_star, Real v, Real reach, Real b) {
  const Real kappa = k / (m_star * v * v);
  const auto g = [&](Real r) { return 1 - b * b / (r * r) - kappa * (reach - r) * (reach - r); };
  Real lo = 0, hi = reach;  // G < 0 near 0, G(reach) > 0, G increasing in between
  for (int i = 0; i < 200; ++i) {
    const Real mid = 0.5 * (lo + hi);
    (g(mid) < 0 ? lo : hi) = mid;
  }
  const Real r_min = hi, span = reach - r_min;
  const auto integrand = [&](Real s) {
    const Real r = r_min + span * s * s;
    const Real h = b * b * (r + r_min) / (r_min * r_min * r * r) + kappa * (2 * reach - r - r_min);
    return 2 * b * std::sqrt(span) / (r * r * std::sqrt(h));
  };
  const int n = 4000;
  Real sum = integrand(0) + integrand(1);
  for (int i = 1; i < n; ++i) sum += (i % 2 ? 4 : 2) * integrand(static_cast<Real>(i) / n);
  return pi - 2 * (std::asin(b / reach) + sum / (3 * n));
}

struct Oblique {
  Real deflection;      // angle between the relative velocities before and after [rad]
  Real speed_out;       // relative speed after [m/s]
  Real energy_error;    // largest |E - E0| / E0 at the ends of steps (kinetic + elastic + dissipated)
  Real angular_error;   // largest |L - L0| / (m* reach v)
};

/// Two spheres (1 kg, 5 cm) at relative speed 1 m/s and impact parameter b, touching at t = 1.37 ms.
Oblique oblique_collision(Real b, Real dt, Real zeta = 0) {
  const Real radius = 0.05, reach = 2 * radius, v = 1, onset = 1.37e-3;
  const Vec3 r0(std::sqrt(reach * reach - b * b) + v * onset, b, 0);
  WorldConfig c = exact_config(dt);
  c.contacts[0].normal_damping = {DampingKind::damping_ratio, zeta};
  c.particles = {test::particle(0.5 * r0, Vec3(-0.5 * v, 0, 0), radius, 1),
                 test::particle(-0.5 * r0, Vec3(0.5 * v, 0, 0), radius, 1)};
  World w(c);
  const auto energy = [&] {
    const Energies e = w.energies();
    return e.kinetic + e.elastic + w.dissipated_energy();
  };
  const auto angular = [&] {
    const State& s = w.state();
    return (s.position[0].cross(s.velocity[0]) + s.position[1].cross(s.velocity[1])).z();
  };
  const Real e0 = energy(), l0 = angular();
  Oblique out{};
  const long steps = static_cast<long>(std::ceil(0.03 / dt));
  for (long s = 0; s < steps; ++s) {
    EXPECT_EQ(w.advance_sync_interval(), StepStatus::ok);
    out.energy_error = std::max(out.energy_error, std::abs(energy() - e0) / e0);
    out.angular_error = std::max(out.angular_error, std::abs(angular() - l0) / (0.5 * reach * v));
  }
  const Vec3 u = w.state().velocity[0] - w.state().velocity[1];  // incoming: (-v, 0, 0)
  out.deflection = std::atan2(u.y(), -u.x());
  out.speed_out = u.norm();
  return out;
}

TEST(ExactStepper, ObliqueCollisionConservesEnergyAndAngularMomentumAtAnyStep) {
  const Real t_c = M_PI * std::sqrt(0.5 / 1e5);  // head-on contact time
  for (Real angle : {30.0, 60.0, 80.0}) {
    const Real b = 0.1 * std::sin(angle * M_PI / 180);
    for (Real dt : {t_c / 50, t_c / 3, t_c, 4 * t_c}) {
      SCOPED_TRACE(testing::Message() << "impact angle " << angle << " dt " << dt);
      const Oblique r = oblique_collision(b, dt);
      EXPECT_LE(r.energy_error, 1e-12);
      EXPECT_LE(r.angular_error, 1e-12);
      EXPECT_NEAR(r.speed_out, 1.0, 1e-12);
    }
  }
}

TEST(ExactStepper, ObliqueCollisionConvergesToTheScatteringIntegralAtSecondOrder) {
  // Review finding: without the centrifugal term the deflection was off by 1e-3..1e-2 at every step.
  const Real t_c = M_PI * std::sqrt(0.5 / 1e5);
  for (Real angle : {30.0, 60.0, 80.0}) {
    SCOPED_TRACE(testing::Message() << "impact angle " << angle);
    const Real b = 0.1 * std::sin(angle * M_PI / 180);
    const Real chi = scattering_angle(1e5, 0.5, 1, 0.1, b);
    // Least-squares order over steps spanning 16x (docs/physics.md 8.6).
    Real sx = 0, sy = 0, sxx = 0, sxy = 0, finest = 0;
    const int n = 5;
    for (int i = 0; i < n; ++i) {
      const Real dt = t_c / (4 << i);
      const Real error = std::abs(oblique_collision(b, dt).deflection - chi);
      const Real x = std::log(dt), y = std::log(error);
      sx += x, sy += y, sxx += x * x, sxy += x * y;
      finest = error;
    }
    const Real order = (n * sxy - sx * sy) / (n * sxx - sx * sx);
    EXPECT_GE(order, 1.8);
    EXPECT_LE(finest, 1e-6);  // at t_c / 64
  }
}

TEST(ExactStepper, DampedObliqueCollisionBooksItsLossAsDissipation) {
  for (Real dt : {1e-4, 1e-3, 1e-2}) {
    SCOPED_TRACE(dt);
    const Oblique r = oblique_collision(0.07, dt, 0.3);
    EXPECT_LT(r.speed_out, 0.99);
    EXPECT_LE(r.energy_error, 1e-12);
    EXPECT_LE(r.angular_error, 1e-12);
  }
}

// ---- Near misses ---------------------------------------------------------------------------------

TEST(ExactStepper, NearMissStaysAMissAtAnyStep) {
  // Spheres passing 1e-3 of the reach beyond contact, closest at t = 0.3 s, with steps up to 30 times
  // the passage: the onset is judged on the true straight relative path (uniform gravity does not
  // bend it), not on the approach along the normal. A graze 1e-3 inside still collides.
  const Real radius = 0.05, reach = 2 * radius, v = 1;
  for (Real miss : {1e-3, -1e-3}) {
    for (bool gravity : {false, true}) {
      for (Real dt : {0.07, 0.25, 1.0, 3.0}) {
        SCOPED_TRACE(testing::Message() << "miss " << miss << " gravity " << gravity << " dt " << dt);
        WorldConfig c = exact_config(dt);
        if (gravity) c.model.gravity = Vec3(0, -3, -9.81);
        const Vec3 r0(0.3 * v, reach * (1 + miss), 0);
        c.particles = {test::particle(0.5 * r0, Vec3(-0.5 * v, 0, 0), radius, 1),
                       test::particle(-0.5 * r0, Vec3(0.5 * v, 0, 0), radius, 1)};
        World w(c);
        const State s0 = w.state();
        advance(w, static_cast<long>(std::ceil(1.0 / dt)));
        const Real t = w.time();
        for (int p = 0; p < 2; ++p) {
          const Vec3 v_free = s0.velocity[p] + t * c.model.gravity;
          const Real change = (w.state().velocity[p] - v_free).norm();
          if (miss < 0) {
            EXPECT_GT(change, 1e-2);
            continue;
          }
          if (gravity) EXPECT_LE(change, 1e-14 * v_free.norm());
          else EXPECT_EQ(w.state().velocity[p], s0.velocity[p]);  // untouched, to the bit
          const Vec3 x_free = s0.position[p] + t * s0.velocity[p] + 0.5 * t * t * c.model.gravity;
          EXPECT_LE((w.state().position[p] - x_free).norm(), 1e-12 * (1 + x_free.norm()));
        }
      }
    }
  }
}

TEST(ExactStepper, NearMissOfAnImmovableSphereUnderGravityStaysAMiss) {
  // A ball thrown over an immovable sphere: the path is a parabola with its apex straight above the
  // sphere's centre at t = 0.3 s, at reach (1 + miss); with v^2 > g reach the apex is the closest
  // point, so 1e-3 beyond contact misses and 1e-3 inside grazes, at any step.
  const Real radius = 0.05, reach = 2 * radius, v = 2, g = 9.81, t_apex = 0.3;
  const Real immovable = std::numeric_limits<Real>::infinity();
  for (Real miss : {1e-3, -1e-3}) {
    for (Real dt : {0.01, 0.07, 0.25, 1.0}) {
      SCOPED_TRACE(testing::Message() << "miss " << miss << " dt " << dt);
      WorldConfig c = exact_config(dt);
      c.model.gravity = Vec3(0, 0, -g);
      const Vec3 x0(-v * t_apex, 0, reach * (1 + miss) - 0.5 * g * t_apex * t_apex), v0(v, 0, g * t_apex);
      c.particles = {test::particle(Vec3::Zero(), Vec3::Zero(), radius, immovable),
                     test::particle(x0, v0, radius, 1)};
      World w(c);
      advance(w, static_cast<long>(std::ceil(2 * t_apex / dt)));
      const Real t = w.time();
      const Vec3 v_free = v0 + t * c.model.gravity;
      const Real change = (w.state().velocity[1] - v_free).norm();
      if (miss > 0) {
        EXPECT_LE(change, 1e-14 * v_free.norm());
        EXPECT_LE((w.state().position[1] - (x0 + t * v0 + 0.5 * t * t * c.model.gravity)).norm(), 1e-12);
      } else {
        EXPECT_GT(change, 1e-2);
      }
    }
  }
}

// ---- Inside a cylinder --------------------------------------------------------------------------

/// A ball (1 kg, 5 cm) inside a static cylinder of radius 1 m along z, no gravity, undamped.
WorldConfig cylinder_config(Real dt, const Vec3& x, const Vec3& v) {
  WorldConfig c = exact_config(dt);
  WallConfig shell;
  shell.kind = WallKind::cylinder;
  shell.axis = Vec3::UnitZ();
  shell.radius = 1;
  c.walls = {shell};
  c.particles = {test::particle(x, v, 0.05, 1)};
  return c;
}

TEST(ExactStepper, BallCirclingInsideACylinderMovesUniformlyAtAnyStep) {
  // Uniform circular motion pressed against the shell: k delta = m u^2 / rho, rho = R - r + delta.
  // Review finding: a normal frozen over the flow leaked 1e-5..1e-3 of the energy in 0.05 s.
  const Real k = 1e5, m = 1, u = 1;
  Real delta = 0;
  for (int i = 0; i < 100; ++i) delta = m * u * u / ((1 - 0.05 + delta) * k);
  const Real rho = 1 - 0.05 + delta, half_period = M_PI * std::sqrt(m / k);
  for (Real dt : {0.05 * half_period, 0.3 * half_period, half_period, 3 * half_period}) {
    SCOPED_TRACE(dt);
    World w(cylinder_config(dt, Vec3(rho, 0, 0), Vec3(0, u, 0)));
    const Real e0 = w.energies().total();
    Real worst = 0;
    for (long s = 0; s < static_cast<long>(std::ceil(1.0 / dt)); ++s) {
      ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
      worst = std::max(worst, std::abs(w.energies().total() - e0));
    }
    const Real phi = u * w.time() / rho;
    EXPECT_LE((w.state().position[0] - rho * Vec3(std::cos(phi), std::sin(phi), 0)).norm(), 1e-9);
    EXPECT_LE((w.state().velocity[0] - u * Vec3(-std::sin(phi), std::cos(phi), 0)).norm(), 1e-9);
    EXPECT_LE(worst, 1e-12 * e0);
  }
}

TEST(ExactStepper, BallBouncingAroundInsideACylinderKeepsEnergyAndAngularMomentum) {
  // Repeated oblique impacts on the shell: the contact force points at the axis, so the angular
  // momentum about it is kept as well as the energy, whatever the step; a spin of the shell about its
  // own axis does not move a frictionless surface.
  const Vec3 x0(0.3, 0.1, 0), v0(0.6, 0.75, 0.2);
  for (Real dt : {1e-3, 1e-2, 0.05}) {
    SCOPED_TRACE(dt);
    WorldConfig c = cylinder_config(dt, x0, v0);
    World w(c);
    c.walls[0].angular_velocity = Vec3(0, 0, 5);
    World spinning(c);
    const auto l_z = [](const World& x) { return x.state().position[0].cross(x.state().velocity[0]).z(); };
    const Real e0 = w.energies().total(), l0 = l_z(w);
    Real worst_e = 0, worst_l = 0;
    const long steps = static_cast<long>(std::ceil(10.0 / dt));  // about six impacts
    for (long s = 0; s < steps; ++s) {
      ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
      ASSERT_EQ(spinning.advance_sync_interval(), StepStatus::ok);
      worst_e = std::max(worst_e, std::abs(w.energies().total() - e0));
      worst_l = std::max(worst_l, std::abs(l_z(w) - l0));
    }
    EXPECT_LE(worst_e, 1e-9 * e0);
    EXPECT_LE(worst_l, 1e-12);
    EXPECT_LE((spinning.state().position[0] - w.state().position[0]).norm(), 1e-12);
    EXPECT_GT((w.state().velocity[0] - v0).norm(), 0.1);  // it did hit the shell
  }
}

TEST(ExactStepper, BallSwingingInACylinderUnderGravityKeepsEnergyToSecondOrder) {
  // Gravity acts on the ball only, so it turns with the contact normal: it pushes along the mean of
  // the stretch's end directions and kicks across by halves, which keeps the stretch symmetric in
  // time: the energy error is bounded and second order in the step, no drift.
  Real previous = 0;
  for (Real dt : {4e-3, 1e-3, 2.5e-4}) {
    SCOPED_TRACE(dt);
    WorldConfig c = cylinder_config(dt, Vec3(0, -0.95, 0), Vec3(1.5, 0, 0.1));
    c.model.gravity = Vec3(0, -9.81, 0);
    World w(c);
    const Real e0 = w.energies().total(), kinetic = w.energies().kinetic;
    Real worst = 0, early = 0, late = 0;
    const long steps = static_cast<long>(std::ceil(5.0 / dt));  // about two swings
    for (long s = 0; s < steps; ++s) {
      ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
      const Real error = std::abs(w.energies().total() - e0) / kinetic;
      worst = std::max(worst, error);
      (s < steps / 2 ? early : late) = std::max(s < steps / 2 ? early : late, error);
    }
    EXPECT_LE(late, 1.5 * early);  // bounded: the second swing is no worse than the first
    if (previous > 0) {
      EXPECT_GE(previous / worst, 12.0);  // 16 for second order
    }
    previous = worst;
  }
  EXPECT_LE(previous, 1e-7);  // at 0.25 ms
}

// ---- Moving walls, retries ----------------------------------------------------------------------

TEST(ExactStepper, WallMuchFasterThanTheParticleIsNotMissed) {
  // Review finding: the wall search padded by the particle's speed, not its speed relative to the
  // wall: a floor rising at 10 m/s passed through a ball at rest once the step was 30 ms.
  const Real m = 1, k = 1e5, r = 0.05, gap = 0.055, v = 10, t_c = M_PI * std::sqrt(m / k);
  for (Real dt : {1e-3, 1e-2, 0.03, 0.06}) {
    SCOPED_TRACE(dt);
    WorldConfig c = exact_config(dt);
    WallConfig floor;
    floor.kind = WallKind::plane;
    floor.velocity = Vec3(0, 0, v);
    c.walls = {floor};
    c.particles = {test::particle(Vec3(0, 0, r + gap), Vec3::Zero(), r, m)};
    World w(c);
    advance(w, static_cast<long>(std::ceil(0.2 / dt)));
    const Real release = gap / v + t_c;
    EXPECT_NEAR(w.state().velocity[0].z(), 2 * v, 1e-9 * v);
    EXPECT_NEAR(w.state().position[0].z(), r + v * release + 2 * v * (w.time() - release), 1e-9);
  }
}

/// exact_step driven directly, for what the World does not show yet (wall work, unresolved steps).
struct BareExact {
  WorldConfig config;
  MaterialTable materials;
  Walls walls;
  State state;
  broadphase::CandidatePairs candidates;
  ExactWorkspace work;
  Real time = 0;

  explicit BareExact(const WorldConfig& c)
      : config(c), materials(c.materials, c.contacts, c.model.separation), walls(c.walls, materials) {
    for (const ParticleConfig& p : c.particles)
      state.add(p.position, p.velocity, Vec3::Zero(), p.radius, 1 / p.mass, 2.5 / (p.mass * p.radius * p.radius), 0);
  }
  void step(Real h, Real skin) {
    broadphase::BruteForceBroadphase().find_pairs(state.position, state.radius, skin, candidates);
    const ExactSettings settings{config.model.separation, config.model.gravity, config.model.dimension};
    exact_step(state, walls, materials, candidates, settings, time, h, work);
    time += h;
  }
};

TEST(ExactStepper, ContactMissedBeyondTheRetriesIsCountedAsUnresolved) {
  // A row of spheres 1 nm apart, the first one moving: within the step each collision passes velocity
  // on to a sphere the anticipation did not include, found only when the step is redone (3 spheres:
  // one redo; 6: three). With fewer redos allowed the step is accepted, and counted, never silently.
  for (int count : {3, 6}) {
    const std::uint64_t needed = count == 3 ? 1 : 3;
    for (int allowed : {0, 1, 2, 8}) {
      SCOPED_TRACE(testing::Message() << count << " spheres, " << allowed << " redos allowed");
      WorldConfig c = exact_config(0.015);
      const Real r = 0.05, gap = 1e-9;
      for (int i = 0; i < count; ++i)
        c.particles.push_back(test::particle(Vec3(i * (2 * r + gap), 0, 0), Vec3(i == 0 ? 1 : 0, 0, 0), r, 1));
      BareExact bare(c);
      bare.work.max_retries = allowed;
      bare.step(0.015, 0.1);
      const bool resolved = needed <= static_cast<std::uint64_t>(allowed);
      EXPECT_EQ(bare.work.retries, resolved ? needed : static_cast<std::uint64_t>(allowed));
      EXPECT_EQ(bare.work.unresolved, resolved ? 0u : 1u);
    }
  }
}

// ---- Work of moving walls -----------------------------------------------------------------------

/// Kinetic + potential + elastic energy of one particle on wall 0 (plane or cylinder) [J].
Real particle_energy(const BareExact& b) {
  const State& s = b.state;
  const Real m = 1 / s.inv_mass[0];
  Real elastic = 0;
  WallTouch t;
  if (b.walls.touch(0, 0, s.position[0], s.radius[0], t))
    elastic = 0.5 * b.config.contacts[0].normal_stiffness * t.overlap * t.overlap;
  return 0.5 * m * s.velocity[0].squaredNorm() - m * b.config.model.gravity.dot(s.position[0]) + elastic;
}

TEST(ExactStepper, WallWorkIsTheEnergyMovingWallsGiveTheParticle) {
  // Undamped: every joule the particle gains is work of the wall, booked as (wall velocity) . (contact
  // impulse) in each flow. A ball bouncing on a rising floor under gravity gains at every bounce; a
  // ball inside a cylinder shell moving sideways is hit by it; a shell spinning about its own axis does
  // no work on a frictionless ball.
  enum Case { rising_floor, sliding_shell, spinning_shell };
  for (Case which : {rising_floor, sliding_shell, spinning_shell}) {
    for (Real dt : {1e-4, 1e-3, 1e-2}) {
      SCOPED_TRACE(testing::Message() << "case " << which << " dt " << dt);
      WorldConfig c = exact_config(dt);
      WallConfig wall;
      if (which == rising_floor) {
        c.model.gravity = Vec3(0, 0, -9.81);
        wall.kind = WallKind::plane;
        wall.velocity = Vec3(0, 0, 0.5);
        c.particles = {test::particle(Vec3(0, 0, 0.3), Vec3(0.2, 0, 0), 0.05, 1)};
      } else {
        wall.kind = WallKind::cylinder;
        wall.radius = 0.5;
        if (which == sliding_shell) wall.velocity = Vec3(0.3, 0.1, 0);
        else wall.angular_velocity = Vec3(0, 0, 7);
        c.particles = {test::particle(Vec3(0.1, 0, 0), Vec3(0.2, 0.4, 0.1), 0.05, 1)};
      }
      c.walls = {wall};
      BareExact bare(c);
      const Real e0 = particle_energy(bare);
      Real worst = 0, scale = e0;
      for (long s = 0; s < static_cast<long>(std::ceil(2.0 / dt)); ++s) {
        bare.step(dt, 0.1);
        worst = std::max(worst, std::abs(particle_energy(bare) - e0 - bare.work.wall_work));
        scale = std::max(scale, std::abs(bare.work.wall_work));
      }
      EXPECT_EQ(bare.work.unresolved, 0u);
      EXPECT_LE(worst, 1e-9 * scale);
      if (which == spinning_shell) EXPECT_EQ(bare.work.wall_work, 0.0);
      else EXPECT_GT(std::abs(bare.work.wall_work), 0.1 * e0);  // the wall did work
    }
  }
}

}  // namespace
}  // namespace dem
