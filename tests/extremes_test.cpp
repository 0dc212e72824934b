// Numerical extremes (docs/physics.md section 9), the short cases of the default suite; the full sweep,
// the 1e7-step runs and the summary table are in extremes_long_test.cpp (label `long`).
//  1. Stiffness 1e2 .. 1e9 N/m at one fixed step (omega0 h from 0.014 to 45): the exact stepper
//     gives the docs/physics.md 2.2 restitution to 1e-9 in both separation conventions; Verlet below the
//     Cundall limit stays within C omega0 h (damped) and C (omega0 h)^2 (undamped) at every k; step
//     doubling at the same base step adapts (the finest level it uses is below the limit).
//  2. Mass ratios: a light particle bounces off a 1e20 kg particle, an infinite-mass particle and a
//     wall alike (m* = m to round-off); pairs up to 1e12 conserve momentum to round-off; m* = 1e-9 kg.
//  3. Damping ratios 0, 1 - 1e-8, 1, 1 + 1e-8 and 1e3: force-zero restitution continuous across
//     critical damping and e^-2 there, the overlap convention's closed form, no rebound energy gained.
//  4. Verlet at 0.5, 1, 1.01, 2 and 10 times the Cundall limit on single contacts and a packing: the
//     run stays bounded, stops with StepStatus::non_finite, or the energy books flag the growth;
//     never a NaN in a state reported ok and never growth the books miss. Doubling on the same
//     setups adapts: bounded energy, restitution near the oracle.
//  5. Tolerances 1e-12 .. 1e-1 terminate, the error falls with the tolerance, forced steps are
//     counted at the tight end.
//  6. Impacts with the overlap up to 1.5 radii and steps carrying a particle several diameters:
//     no pass-through, the overlap bounded by the law's and flagged when beyond 0.5 R; deeper impacts
//     (2.5 R) flagged under every stepper; fixed Verlet steps longer than the particle never tunnel
//     unflagged.
//  7. 30 and 40 levels between level_min and level_max keep integer time exact.
//  8. The energy books of undamped runs show no dissipation.
// Every expected value comes from docs/physics.md formulas or conservation laws; none is copied from the
// engine's output.
//
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"
#include "tests/extremes_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

// ---------------------------------------------------------------------------------------------
// 1. Stiffness 1e2 .. 1e9 N/m

TEST(Extremes, ExactHeadOnPairMatchesTheOracleForStiffness1e2To1e9AtOneStep) {
  // dt = 1 ms for every k: omega0 h from 0.014 (k = 1e2) to 45 (k = 1e9), the whole contact inside
  // one step at the stiff end. docs/physics.md 5.3: the isolated pair is exact at any step.
  Real worst = 0;
  for (Separation sep : {Separation::force_zero, Separation::overlap})
    for (Real zeta : {0.0, 0.1, 0.5})
      for (Real k : decades_of_stiffness) {
        SCOPED_TRACE(::testing::Message() << "k " << k << " zeta " << zeta << " separation " << static_cast<int>(sep));
        const PairRun r = head_on_pair({Method::exact, Control::fixed}, k, zeta, sep, 1e-3);
        const Real e = restitution_oracle(zeta, sep);
        EXPECT_NEAR(r.restitution, e, 1e-9);
        EXPECT_LE(r.momentum_error, momentum_budget(r.particle_steps));
        EXPECT_EQ(r.audit.outcome, Outcome::bounded);
        expect_sound(r.audit);
        worst = std::max(worst, std::abs(r.restitution - e));
      }
  RecordProperty("max_restitution_error", sci(worst));
}

TEST(Extremes, VerletHeadOnPairStaysWithinItsErrorBoundForStiffness1e2To1e9) {
  // Below the Cundall limit the error is a function of omega0 h alone: the same bound at every k,
  // 4 onset phases (the maximum over phases is what the bound covers).
  Real worst_damped = 0, worst_undamped = 0;
  for (Real k : {1e2, 1e5, 1e9})
    for (Real w0h : {0.05, 0.2})
      for (Real zeta : {0.0, 0.1})
        for (Separation sep : {Separation::force_zero, Separation::overlap}) {
          const Real dt = w0h / std::sqrt(k / 0.5), e = restitution_oracle(zeta, sep);
          for (Real phase : {0.0, 0.25, 0.5, 0.75}) {
            SCOPED_TRACE(::testing::Message() << "k " << k << " omega0 h " << w0h << " zeta " << zeta << " phase " << phase);
            const Collision col = head_on(k, Damping{DampingKind::damping_ratio, zeta}, sep, dt, 0.1, phase, 5, 1.0, 0.05);
            const Real error = std::abs(col.restitution - e);
            if (zeta > 0) {
              EXPECT_LE(error, kRestitutionC * w0h);
              worst_damped = std::max(worst_damped, error / w0h);
            } else {
              EXPECT_LE(error, kUndampedC * w0h * w0h);
              worst_undamped = std::max(worst_undamped, error / (w0h * w0h));
            }
          }
        }
  RecordProperty("max_damped_error_over_omega0_h", sci(worst_damped));
  RecordProperty("max_undamped_error_over_omega0_h_squared", sci(worst_undamped));
}

TEST(Extremes, DoublingAtOneBaseStepAdaptsToStiffness1e2To1e9) {
  // dt_base = 1 ms at level_max 0, level_min -20, tolerance 1e-6, zeta = 0.1. Verlet must demote
  // below the Cundall limit (omega0 h < 2) wherever level 0 is beyond it, and keep the restitution
  // within 1e-4 of the oracle (100 x the per-step tolerance over a contact of ~100 fine steps); the
  // exact stepper needs no demotion and stays exact.
  for (Method method : {Method::verlet, Method::exact})
    for (Real k : decades_of_stiffness) {
      SCOPED_TRACE(::testing::Message() << method_name(method) << " k " << k);
      const PairRun r = head_on_pair({method, Control::doubling}, k, 0.1, Separation::force_zero, 1e-3);
      const Real e = restitution_oracle(0.1, Separation::force_zero);
      const Real omega_h_finest = std::sqrt(k / 0.5) * std::ldexp(1e-3, r.finest);
      EXPECT_EQ(r.audit.outcome, Outcome::bounded);
      expect_sound(r.audit);
      EXPECT_LE(r.momentum_error, momentum_budget(r.particle_steps));
      if (method == Method::verlet) {
        EXPECT_NEAR(r.restitution, e, 1e-4);
        EXPECT_LT(omega_h_finest, 2.0) << "finest level " << r.finest;
      } else {
        EXPECT_NEAR(r.restitution, e, 1e-9);
      }
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Mass ratios and tiny reduced masses

TEST(Extremes, LightParticleBouncesOffA1e20KgParticleAnInfiniteMassAndAWallAlike) {
  // docs/physics.md 1.3: m* = 1 / (1/m + 1e-20) = m to round-off, so all three give the same bounce.
  // Round-off: the overlap is a difference of positions of size ~R = 100 delta_max, so each
  // evaluation carries ~eps R / delta_max = 2e-14 of relative error; 1e-12 allows 50 of them.
  for (Method method : {Method::verlet, Method::exact}) {
    SCOPED_TRACE(method_name(method));
    const LightOnHeavy wall = light_on(method, 0, true);
    const LightOnHeavy heavy = light_on(method, 1e20, false);
    const LightOnHeavy immovable = light_on(method, std::numeric_limits<Real>::infinity(), false);
    for (const LightOnHeavy* r : {&wall, &heavy, &immovable}) {
      EXPECT_EQ(r->audit.outcome, Outcome::bounded);
      expect_sound(r->audit);
    }
    EXPECT_NEAR(heavy.light_velocity, wall.light_velocity, 1e-12 * light_v);
    EXPECT_NEAR(immovable.light_velocity, wall.light_velocity, 1e-12 * light_v);
    // The restitution of docs/physics.md 2.2 with m* = m: exact to 1e-9; Verlet within C omega0 h.
    const Real e = restitution_oracle(light_zeta, Separation::force_zero);
    EXPECT_NEAR(-wall.light_velocity / light_v, e, method == Method::exact ? 1e-9 : kRestitutionC * 0.05);
    // The 1e20 kg particle takes the impulse (1 + e) m v: its velocity is (1 + e) m v / M.
    const Real impulse = light_m * (light_v - heavy.light_velocity);
    EXPECT_NEAR(heavy.heavy_velocity * 1e20, impulse, 1e-9 * impulse);
    EXPECT_LE(heavy.heavy_shift, 1e-15);
    // The infinite mass does not move at all, to the bit.
    EXPECT_EQ(immovable.heavy_velocity, 0.0);
    EXPECT_EQ(immovable.heavy_shift, 0.0);
  }
}

TEST(Extremes, PairsWithMassRatiosUpTo1e12ConserveMomentumAndMatchTheRestitution) {
  // zeta is given, so the relative restitution is the oracle's at every m* (docs/physics.md 2.2);
  // momentum, the heavy particle's included (its velocity ~1e-14 m/s at 1e12), to round-off.
  for (Method method : {Method::verlet, Method::exact})
    for (Real ratio : {1.0, 1e3, 1e6, 1e12}) {
      SCOPED_TRACE(::testing::Message() << method_name(method) << " M/m " << ratio);
      const LightOnHeavy r = light_on(method, ratio * light_m, false);
      EXPECT_EQ(r.audit.outcome, Outcome::bounded);
      expect_sound(r.audit);
      EXPECT_NEAR(r.restitution, restitution_oracle(light_zeta, Separation::force_zero),
                  method == Method::exact ? 1e-9 : kRestitutionC * 0.05);
      EXPECT_LE(r.momentum_error, momentum_budget(r.particle_steps));
    }
}

TEST(Extremes, ReducedMassOf1e9KgBouncesWithTheOracleRestitution) {
  // Two 2e-9 kg spheres of radius 0.1 mm (m* = 1e-9 kg), and one on a wall (m* = m = 1e-9 kg), k from
  // 1e-2 to 1e9 N/m (omega0 from 3e3 to 1e9 1/s); the approach speed is 0.01 omega0 R so that
  // delta_max = 0.01 R at every k (up to 1 km/s at k = 1e9: the extreme is m*, not the overlap).
  const Real r = 1e-4;
  const Real e = restitution_oracle(light_zeta, Separation::force_zero);
  for (Method method : {Method::verlet, Method::exact})
    for (Real k : {1e-2, 1.0, 1e2, 1e5, 1e9})
      for (bool wall : {false, true}) {
        SCOPED_TRACE(::testing::Message() << method_name(method) << " k " << k << (wall ? " wall" : " pair"));
        const Real m = wall ? 1e-9 : 2e-9, omega0 = std::sqrt(k / 1e-9), v = 0.01 * omega0 * r, gap = 1e-3 * r;
        const Real dt = (method == Method::exact ? 3.0 : 0.05) / omega0;
        const Damping d{DampingKind::damping_ratio, light_zeta};
        WorldConfig c = wall ? wall_impact(method, k, d, dt, r, m, v, gap) : pair_impact(method, k, d, dt, r, m, m, v, gap);
        World w(c);
        const AuditResult a = run_audited(w, static_cast<long>(std::ceil((gap / v + 10 / omega0) / dt)) + 5);
        EXPECT_EQ(a.outcome, Outcome::bounded);
        expect_sound(a);
        const Real restitution = wall ? w.velocity(0).x() / v : pair_restitution(w, v);
        EXPECT_NEAR(restitution, e, method == Method::exact ? 1e-9 : kRestitutionC * 0.05);
        if (!wall) {
          EXPECT_LE(std::abs(w.linear_momentum().x() - m * v), momentum_budget(w.counters().particle_steps) * m * v);
        }
      }
}

// ---------------------------------------------------------------------------------------------
// 3. Damping ratios 0 .. 1e3

TEST(Extremes, ExactStepperDampingRatiosFrom0To1e3MatchTheClosedForms) {
  const Real e_critical = std::exp(-2.0);
  for (Real zeta : extreme_ratios) {
    SCOPED_TRACE(::testing::Message() << "zeta " << zeta);
    // Force-zero: the restitution of docs/physics.md 2.2 in its three branches.
    const WallDamped fz = damped_on_wall(Method::exact, zeta, Separation::force_zero, 0.7);
    EXPECT_EQ(fz.audit.outcome, Outcome::bounded);
    expect_sound(fz.audit);
    const Real e = restitution_oracle(zeta, Separation::force_zero);
    EXPECT_NEAR(fz.restitution, e, 1e-9 * e + 1e-15);
    EXPECT_LE(fz.restitution, 1.0 + 1e-12);  // no rebound energy gained
    EXPECT_GE(fz.restitution, 0.0);
    // Continuity across zeta = 1: e = e^-2 there, and within |de/dzeta| 1e-8 of it 1e-8 away.
    if (std::abs(zeta - 1) <= 1e-8) {
      EXPECT_NEAR(fz.restitution, e_critical, zeta == 1 ? 1e-9 : 1e-7);
    }
    // Overlap convention: no rebound for zeta >= 1 (nor, in this time, at 1 - 1e-8, whose contact lasts
    // pi / omega_d = 22000 / omega0): the particle follows the closed-form oscillator, still in contact.
    const WallDamped ov = damped_on_wall(Method::exact, zeta, Separation::overlap, 0.7);
    EXPECT_EQ(ov.audit.outcome, Outcome::bounded);
    expect_sound(ov.audit);
    if (zeta == 0) {
      EXPECT_NEAR(ov.restitution, 1.0, 1e-9);
    } else {
      // At zeta = 1e3 the slow mode leaves delta ~ v / (2 zeta omega0) = 5e-8 m; near zeta = 1 delta is
      // ~1e-87 m by now, below the round-off of the positions, so the list may have dropped it.
      if (zeta > 10) {
        EXPECT_TRUE(ov.in_contact);
      }
      EXPECT_LE(ov.rate_error, 1e-9);
      EXPECT_LE(ov.restitution, 1e-6);  // creeping out at most: v / (4 zeta^2) for zeta = 1e3
    }
  }
}

TEST(Extremes, VerletDampingRatiosFrom0To1e3StayWithinTheirBoundOrAreFlagged) {
  // At omega0 h = 0.05 (below the undamped limit 2), zeta up to 1 + 1e-8: within C omega0 h. For
  // zeta = 1e3 the damped limit 2 (sqrt(1 + zeta^2) - zeta) = 1e-3 (docs/physics.md 4.2) is far below: at
  // omega0 h = 5e-4 the restitution stays in [0, 1] near the oracle; at 0.05 the explicit dashpot
  // throws the particle back with more energy than it came with, which must be flagged.
  for (Real zeta : extreme_ratios) {
    SCOPED_TRACE(::testing::Message() << "zeta " << zeta);
    const Real w0h = zeta < 10 ? 0.05 : 5e-4;
    const WallDamped fz = damped_on_wall(Method::verlet, zeta, Separation::force_zero, w0h);
    EXPECT_EQ(fz.audit.outcome, Outcome::bounded);
    expect_sound(fz.audit);
    EXPECT_NEAR(fz.restitution, restitution_oracle(zeta, Separation::force_zero),
                zeta == 0 ? kUndampedC * w0h * w0h : kRestitutionC * w0h);
    EXPECT_LE(fz.restitution, 1.0 + kUndampedC * w0h * w0h);
    EXPECT_GE(fz.restitution, 0.0);
    const WallDamped ov = damped_on_wall(Method::verlet, zeta, Separation::overlap, w0h);
    expect_sound(ov.audit);
    if (zeta > 0) {
      EXPECT_LE(std::abs(ov.restitution), kRestitutionC * w0h);  // no rebound
    }
  }
  const WallDamped beyond = damped_on_wall(Method::verlet, 1e3, Separation::force_zero, 0.05);
  expect_sound(beyond.audit);
  EXPECT_TRUE(beyond.audit.outcome != Outcome::bounded || beyond.restitution <= 1.0)
      << "rebound energy gained without a flag: e = " << beyond.restitution;
  RecordProperty("zeta_1e3_beyond_damped_limit_outcome", outcome_name(beyond.audit.outcome));
}

// ---------------------------------------------------------------------------------------------
// 4. Beyond the Cundall-Strack limit

TEST(Extremes, VerletAndExactBeyondTheCundallLimitStayBoundedOrStopWithADiagnosis) {
  // dt = f x 2 sqrt(m*/k) for f = 0.5, 1, 1.01, 2, 10 (docs/physics.md 4.2): whatever happens, never a NaN
  // in an ok state and never growth the books miss (expect_sound). Beyond that, physics:
  //  - Verlet at f = 0.5 (omega0 h = 1) on one undamped contact conserves the shadow energy
  //    H - (h^2/8) F^2/m, so E <= E0 / (1 - (omega0 h)^2 / 4): a rise of at most 1/3;
  //  - the exact stepper on one isolated contact is exact at any f (e = 1, or the damped oracle).
  for (Real f : cundall_factors) {
    for (Method method : {Method::verlet, Method::exact}) {
      const Stepper s{method, Control::fixed};
      for (CundallScene scene : {CundallScene::pair, CundallScene::walls, CundallScene::packing}) {
        SCOPED_TRACE(::testing::Message() << stepper_name(s) << ", " << scene_name(scene) << ", f " << f);
        const CundallRun r = run_cundall(scene, s, f, scene == CundallScene::pair ? 100 : 2000);
        expect_sound(r.audit);
        std::printf("Cundall f %.2f, %s, %s: %s after %ld intervals, max rise %.3g E0, books %.3g\n", f,
                    stepper_name(s).c_str(), scene_name(scene), outcome_name(r.audit.outcome), r.audit.intervals,
                    r.audit.max_rise, r.audit.max_book_error);
        if (scene == CundallScene::pair && method == Method::exact) {
          EXPECT_EQ(r.audit.outcome, Outcome::bounded);
          EXPECT_NEAR(r.restitution, 1.0, 1e-9);
        }
        if (scene == CundallScene::pair && method == Method::verlet && f == 0.5) {
          EXPECT_LE(r.audit.max_rise, 1 / (1 - 0.25) - 1);
        }
      }
    }
    // A damped pair (zeta = 0.1: the damped limit is 2 (sqrt(1.01) - 0.1) = 1.81 / omega0).
    const CundallRun damped = run_cundall(CundallScene::pair, {Method::verlet, Control::fixed}, f, 100, 0.1);
    expect_sound(damped.audit);
    const CundallRun exact = run_cundall(CundallScene::pair, {Method::exact, Control::fixed}, f, 100, 0.1);
    EXPECT_NEAR(exact.restitution, restitution_oracle(0.1, Separation::force_zero), 1e-9) << "f " << f;
  }
}

TEST(Extremes, DoublingBeyondTheCundallLimitAdapts) {
  // The same setups with level_max at f x the limit, level_min 12 levels below, tolerance 1e-4: the
  // controller demotes Verlet below the limit (omega h < 2 at the finest level used), the energy
  // stays within 3e-2 of E0 (docs/physics.md 8.6: the bound for multi-contact runs at omega_max h = 1.5),
  // nothing is flagged, and the damped pair's restitution is within 1e-3 of the oracle (ten times the
  // tolerance). The packing at f = 10 is in the long suite (a few seconds).
  for (Real f : cundall_factors)
    for (Method method : {Method::verlet, Method::exact}) {
      const Stepper s{method, Control::doubling};
      for (CundallScene scene : {CundallScene::pair, CundallScene::walls, CundallScene::packing}) {
        if (scene == CundallScene::packing && f > 2) continue;
        SCOPED_TRACE(::testing::Message() << stepper_name(s) << ", " << scene_name(scene) << ", f " << f);
        const long intervals = scene == CundallScene::pair ? 100 : scene == CundallScene::walls ? 300 : 100;
        const CundallRun r = run_cundall(scene, s, f, intervals, scene == CundallScene::pair ? 0.1 : 0.0);
        expect_sound(r.audit);
        EXPECT_EQ(r.audit.outcome, Outcome::bounded);
        // Undamped scenes conserve energy; the damped pair may only lose it.
        EXPECT_LE(scene == CundallScene::pair ? r.audit.max_rise : r.audit.max_change, 3e-2);
        if (method == Method::verlet) {
          EXPECT_LT(r.omega_h_finest, 2.0);
        }
        if (scene == CundallScene::pair) {
          EXPECT_NEAR(r.restitution, restitution_oracle(0.1, Separation::force_zero), method == Method::exact ? 1e-9 : 1e-3);
        }
      }
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Tolerances 1e-12 .. 1e-1

TEST(Extremes, TolerancesFrom1e12To1e1TerminateAndCountForcedSteps) {
  const std::vector<Real> tolerances{1e-1, 1e-3, 1e-6, 1e-9, 1e-12};
  const Real omega_h_min = 4 * std::ldexp(1.0, tol_level_min);
  // Termination with bounded work: each accepted step costs at most 3 trials per level it can drop.
  const std::uint64_t work_bound = 3 * static_cast<std::uint64_t>(tol_intervals) * (std::uint64_t{1} << -tol_level_min) *
                                   static_cast<std::uint64_t>(1 - tol_level_min);
  for (Method method : {Method::verlet, Method::exact}) {
    SCOPED_TRACE(method_name(method));
    std::vector<ToleranceRun> runs;
    for (Real tol : tolerances) {
      runs.push_back(tolerance_run(method, tol));
      const ToleranceRun& r = runs.back();
      EXPECT_EQ(r.audit.intervals, tol_intervals) << "tolerance " << tol;
      expect_sound(r.audit);
      EXPECT_LE(r.particle_steps, work_bound);
      std::printf("tolerance %.0e, %s: |e - e_oracle| %.3e, forced %llu of %llu particle-steps\n", tol,
                  method_name(method), r.error, static_cast<unsigned long long>(r.forced),
                  static_cast<unsigned long long>(r.particle_steps));
    }
    if (method == Method::exact) {
      // Exact for an isolated contact: no error to control at any tolerance.
      for (const ToleranceRun& r : runs) EXPECT_LE(r.error, 1e-9);
      continue;
    }
    // The error falls as the tolerance tightens down to 1e-6; tighter, the steps reach level_min and
    // are force-accepted, and the error is that of level_min (<= C omega0 h_min), not above 1e-6's.
    EXPECT_LE(runs[1].error, runs[0].error);
    EXPECT_LE(runs[2].error, runs[1].error);
    EXPECT_LE(runs[3].error, runs[2].error);
    EXPECT_LE(runs[4].error, runs[2].error);
    EXPECT_LE(runs[4].error, kRestitutionC * omega_h_min);
    // Forced steps: none at 1e-1, counted at the tight end, never fewer as the tolerance tightens.
    EXPECT_EQ(runs[0].forced, 0u);
    EXPECT_GT(runs[4].forced, 0u);
    for (std::size_t q = 1; q < runs.size(); ++q) EXPECT_GE(runs[q].forced, runs[q - 1].forced);
  }
  // A packing (36 discs, many coupled contacts) at 1e-12 with 4 levels: it ends its interval, with
  // forced steps counted, within the same work bound.
  for (Method method : {Method::verlet, Method::exact}) {
    SCOPED_TRACE(method_name(method));
    WorldConfig c = packing_config(method);
    Real omega_max = 0;
    {
      const World probe(c);
      omega_max = omega_max_bound(probe);
    }
    set_doubling(c, 0.3 / omega_max, -4, 0, 1e-12);
    World w(c);
    const AuditResult a = run_audited(w, 1);
    EXPECT_EQ(a.intervals, 1);
    expect_sound(a);
    EXPECT_GT(w.counters().forced_steps, 0u);
    EXPECT_LE(w.counters().particle_steps, 3u * 36u * 16u * 5u);
  }
}

// ---------------------------------------------------------------------------------------------
// 6. Overlap comparable to the radius; steps longer than the particle
TEST(Extremes, ImpactsWithOverlapsUpToOneAndAHalfRadiiBounceOnTheirSideAndAreFlagged) {
  // Up to delta_max = 1.5 R the linear law still stops the particle (the centre of one on a wall goes
  // 0.5 R behind the plane, but the particle never gets wholly behind it; a pair's centres never
  // cross). So: no pass-through, the oracle restitution 1 (exact: 1e-9; Verlet at omega0 h = 0.02:
  // C (omega0 h)^2; doubling: 1e-3), an overlap at sync times never beyond the law's (bounded), and
  // where the sync times sample the contact finely (omega0 h = 0.02) the overlap is flagged as soon as
  // it is beyond 0.5 R: deepest_overlap reports it.
  for (Target target : {Target::wall, Target::particle})
    for (Real ratio : {0.5, 1.0, 1.5})
      for (const DeepConfig& config : deep_configs) {
        SCOPED_TRACE(::testing::Message() << target_name(target) << ", delta_max / R " << ratio << ", "
                                          << stepper_name(config.stepper) << ", omega0 dt " << config.omega_dt);
        const Impact r = deep_impact(target, config, ratio);
        expect_sound(r.audit);
        EXPECT_FALSE(r.end.passed_through()) << "side " << r.end.side << " rate " << r.end.rate;
        const bool exact = config.stepper.method == Method::exact;
        const Real tol = exact ? 1e-9
                         : config.stepper.control == Control::doubling ? 1e-3
                                                                        : kUndampedC * config.omega_dt * config.omega_dt;
        EXPECT_NEAR(r.end.restitution, 1.0, tol);
        EXPECT_LE(r.audit.max_overlap, ratio * (1 + (exact ? 1e-9 : 1e-2)));
        if (config.omega_dt <= 0.02) {
          EXPECT_GE(r.audit.max_overlap, ratio * (1 - 1e-3));
          if (ratio > kOverlapLimit) {
            EXPECT_EQ(r.audit.outcome, Outcome::flagged_overlap);
          }
        }
      }
}

TEST(Extremes, ImpactsWhoseOverlapWouldExceedTheDiameterAreFlaggedByEveryStepper) {
  // delta_max = 2.5 R: the linear law cannot stop the particle before it is wholly behind the wall
  // (overlap 2R) or the centres cross. docs/physics.md 9.2: flag the non-physical overlap, never pass
  // through. Velocity Verlet's overlap is watched after every step (fixed) or accepted step (doubling); the
  // exact stepper, where a whole impact may fit in one step (omega0 dt up to 10), reports the
  // deepest overlap inside the step (normal_flow.h, OverlapWatch). So every such impact is flagged,
  // at the law's own depth, before it can pass through; `dem run` stops there and keeps the last good
  // state (cli_divergence_test.cpp). The particle may then go on through the wall in this audit,
  // which does not stop on an overlap flag. (Before the watch, 6 of these 12 were never flagged:
  // bounced from 2.5 R, or passed through under doubling.)
  for (Target target : {Target::wall, Target::particle})
    for (const DeepConfig& config : deep_configs) {
      SCOPED_TRACE(::testing::Message() << target_name(target) << ", " << stepper_name(config.stepper) << ", omega0 dt "
                                        << config.omega_dt);
      const Impact r = deep_impact(target, config, 2.5);
      expect_sound(r.audit);
      EXPECT_EQ(r.audit.outcome, Outcome::flagged_overlap);
      EXPECT_GT(r.audit.max_overlap, kOverlapLimit);
    }
}

TEST(Extremes, StepsCarryingAParticleSeveralDiametersDoNotTunnelWithExactOrDoubling) {
  // The exact stepper finds the onset on the true path; doubling's anticipation demotes before the
  // contact (docs/physics.md 6.8). The bounce is elastic and the overlap never beyond the law's 0.1 R.
  for (Target target : {Target::wall, Target::particle})
    for (Real diameters : {1.5, 3.0, 30.0})
      for (Stepper s : {Stepper{Method::exact, Control::fixed}, Stepper{Method::exact, Control::doubling},
                        Stepper{Method::verlet, Control::doubling}}) {
        SCOPED_TRACE(::testing::Message() << target_name(target) << ", v dt = " << diameters << " x 2R, " << stepper_name(s));
        const Impact r = tunnelling_impact(target, s, diameters);
        expect_sound(r.audit);
        EXPECT_EQ(r.audit.outcome, Outcome::bounded);
        EXPECT_FALSE(r.end.passed_through()) << "side " << r.end.side << " rate " << r.end.rate;
        EXPECT_NEAR(r.end.restitution, 1.0, s.method == Method::exact ? 1e-9 : 1e-3);
        EXPECT_LE(r.audit.max_overlap, 0.1 * 1.01);
      }
}

TEST(Extremes, VerletAtAFixedStepLongerThanTheParticleDoesNotTunnelSilently) {
  // Velocity Verlet at a fixed step cannot resolve the contact, but docs/physics.md 9.2 asks that the
  // particle never pass through silently: the World watches h |v| / R after every step and `dem run`
  // warns beyond 1 (a step that long can step over a contact). Every configuration must end on its
  // side, or be flagged by that watch (or by the energy books or the overlap watch).
  for (Target target : {Target::wall, Target::particle})
    for (Real diameters : {1.5, 3.0, 30.0}) {
      SCOPED_TRACE(::testing::Message() << target_name(target) << ", v dt = " << diameters << " x 2R");
      const Impact r = tunnelling_impact(target, {Method::verlet, Control::fixed}, diameters);
      expect_sound(r.audit);
      EXPECT_TRUE(!r.end.passed_through() || r.audit.outcome != Outcome::bounded)
          << "passed through silently: side " << r.end.side << " m, rate " << r.end.rate << " m/s";
      // The watch itself: the approach speed v carries the particle v dt / R = 2 x diameters radii.
      EXPECT_GE(r.audit.max_travel, 2 * diameters * (1 - 1e-12));
    }
}

// ---------------------------------------------------------------------------------------------
// 7. 30 and 40 levels

TEST(Extremes, ThirtyAndFortyLevelsKeepIntegerTimeExact) {
  for (Method method : {Method::verlet, Method::exact})
    for (int levels : {30, 40}) {
      SCOPED_TRACE(::testing::Message() << method_name(method) << ", " << levels << " levels");
      const long n = 200;
      const LevelsRun r = levels_run(method, levels, n);
      EXPECT_EQ(r.audit.intervals, n);
      EXPECT_EQ(r.audit.non_finite_ok, 0);
      EXPECT_TRUE(r.clock_exact) << "clock or time() off after some interval";
      EXPECT_TRUE(r.ticks_covered) << "accepted steps do not cover the intervals' ticks exactly";
      // Free flight is exact at any step: only round-off, ~ n eps |x| (docs/physics.md 8.1).
      EXPECT_LE(r.free_error, 4.0 * n * kEps * 11.0);
      EXPECT_LE(r.energy_change, method == Method::exact ? 1e-10 : 1e-2);
      EXPECT_EQ(r.forced, 0u) << "the contact never needs level_min";
      if (method == Method::verlet) {
        EXPECT_LT(r.finest, -4) << "the contact was resolved at fine levels";
      }
    }
}

// ---------------------------------------------------------------------------------------------
// 8. Energy books of undamped runs

TEST(Extremes, EnergyBooksOfAnUndampedExactRunShowNoDissipation) {
  const BooksRun r = books_run(Method::exact, 0.7, 8000);
  EXPECT_GE(r.contacts, 400);
  EXPECT_LE(r.energy_error, 1e-10);
  EXPECT_LE(std::abs(r.dissipated), 1e-10);
  EXPECT_LE(std::abs(r.book_error), 1e-10);
}

TEST(Extremes, EnergyBooksOfAnUndampedVerletRunShowNoDissipation) {
  // An undamped contact dissipates nothing, whatever the step: the books must show no dissipation
  // (round-off), and their balance error is then velocity Verlet's own energy error, never more.
  // (Before the steps on which a contact forms and parts were booked from delta = 0, each impact
  // showed ~0.17 (omega0 h)^2 of its energy as dissipated, always positive: after ~600 impacts the
  // books held more than E0 and flagged growth that never happened.) One sphere between two walls
  // keeps |E - E0| <= 0.5 (omega0 h)^2 E0 (contact_scenes.h); two spheres that also meet each other
  // random-walk in energy from impact to impact, so only the books are checked there.
  const Real w0h = 0.1;
  for (bool pair : {false, true}) {
    SCOPED_TRACE(pair ? "two spheres: pair and wall contacts" : "one sphere: wall contacts");
    const BooksRun r = books_run(Method::verlet, w0h, 50'000, pair);
    std::printf("undamped Verlet, omega0 h = %.2f, %ld contacts: |dE| %.3e E0, books: dissipated %.3e E0, "
                "balance error %.3e of the energy in play\n",
                w0h, r.contacts, r.energy_error, r.dissipated, r.book_error);
    EXPECT_GE(r.contacts, 400);
    if (!pair) {
      EXPECT_LE(r.energy_error, 0.5 * w0h * w0h);  // the integrator itself is sound
    }
    EXPECT_LE(std::abs(r.dissipated), 1e-9);
    EXPECT_LE(std::abs(r.book_error), r.energy_error + 1e-9);
  }
}

}  // namespace
}  // namespace dem
