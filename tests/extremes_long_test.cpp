// Numerical extremes (docs/physics.md section 9), the full sweep of the `long` label: the ranges of the
// default suite (extremes_test.cpp) sampled densely, the packing at 10 x the Cundall limit under
// doubling, 30 levels over 1e6 sync intervals, and 1e7-step undamped runs with energy and momentum
// drift budgets. Every test writes its section of a Markdown summary table (one row per case: case,
// parameters, stepper / control, outcome, measured figure against its bound) to the path in
// DEM_EXTREMES_TABLE, or to extremes_summary.md in the working directory.
// Every expected value comes from docs/physics.md formulas or conservation laws; none is copied from the
// engine's output.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
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

std::string outcome_count(int bounded, int total) {
  return bounded == total ? "bounded (" + std::to_string(total) + " runs)"
                          : std::to_string(bounded) + " of " + std::to_string(total) + " bounded";
}

std::vector<Real> half_decades(Real from, Real to) {
  std::vector<Real> out;
  for (Real e = std::log10(from); e <= std::log10(to) + 1e-9; e += 0.5) out.push_back(std::pow(10.0, e));
  return out;
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, StiffnessFrom1e2To1e9) {
  const std::vector<Real> ks = half_decades(1e2, 1e9);
  std::vector<TableRow> rows;
  const std::string k_range = "k = 1e2 .. 1e9 N/m, half decades (15)";
  {  // exact, fixed 1 ms step: omega0 h = 0.014 .. 45
    Real worst = 0;
    int bounded = 0, total = 0;
    for (Separation sep : {Separation::force_zero, Separation::overlap})
      for (Real zeta : {0.0, 0.1, 0.5, 0.9, 1.0, 3.0})
        for (Real k : ks) {
          if (sep == Separation::overlap && zeta >= 1) continue;  // no rebound: section 4
          const PairRun r = head_on_pair({Method::exact, Control::fixed}, k, zeta, sep, 1e-3);
          expect_sound(r.audit);
          worst = std::max(worst, std::abs(r.restitution - restitution_oracle(zeta, sep)));
          bounded += r.audit.outcome == Outcome::bounded;
          ++total;
        }
    EXPECT_LE(worst, 1e-9);
    EXPECT_EQ(bounded, total);
    rows.push_back({"head-on pair, restitution", k_range + "; zeta 0 .. 3, both conventions; dt = 1 ms (omega0 h 0.014 .. 45)",
                    "exact / fixed", outcome_count(bounded, total), verdict("max abs(e - e_oracle)", worst, 1e-9)});
  }
  {  // Verlet, fixed, below the limit: 8 onset phases
    Real worst_damped = 0, worst_undamped = 0;
    int runs = 0;
    for (Real k : ks)
      for (Real w0h : {0.02, 0.05, 0.2})
        for (Real zeta : {0.0, 0.1})
          for (Separation sep : {Separation::force_zero, Separation::overlap})
            for (int phase = 0; phase < 8; ++phase) {
              const Real dt = w0h / std::sqrt(k / 0.5);
              const Collision col = head_on(k, Damping{DampingKind::damping_ratio, zeta}, sep, dt, 0.1, phase / 8.0, 5, 1.0, 0.05);
              const Real error = std::abs(col.restitution - restitution_oracle(zeta, sep));
              ++runs;
              if (zeta > 0) worst_damped = std::max(worst_damped, error / w0h);
              else worst_undamped = std::max(worst_undamped, error / (w0h * w0h));
            }
    EXPECT_LE(worst_damped, kRestitutionC);
    EXPECT_LE(worst_undamped, kUndampedC);
    const std::string params = k_range + "; omega0 h 0.02, 0.05, 0.2; 8 onset phases; both conventions";
    rows.push_back({"head-on pair, zeta = 0.1", params, "verlet / fixed", "ok (" + std::to_string(runs / 2) + " runs)",
                    verdict("max abs(e - e_oracle) / (omega0 h)", worst_damped, kRestitutionC)});
    rows.push_back({"head-on pair, undamped", params, "verlet / fixed", "ok (" + std::to_string(runs / 2) + " runs)",
                    verdict("max abs(e - 1) / (omega0 h)^2", worst_undamped, kUndampedC)});
  }
  for (Method method : {Method::verlet, Method::exact}) {  // doubling at one base step
    Real worst = 0, worst_finest = 0;
    int bounded = 0;
    for (Real k : ks) {
      const PairRun r = head_on_pair({method, Control::doubling}, k, 0.1, Separation::force_zero, 1e-3);
      expect_sound(r.audit);
      worst = std::max(worst, std::abs(r.restitution - restitution_oracle(0.1, Separation::force_zero)));
      worst_finest = std::max(worst_finest, std::sqrt(k / 0.5) * std::ldexp(1e-3, r.finest));
      bounded += r.audit.outcome == Outcome::bounded;
    }
    const Real bound = method == Method::exact ? 1e-9 : 1e-4;
    EXPECT_LE(worst, bound) << method_name(method);
    EXPECT_EQ(bounded, static_cast<int>(ks.size()));
    std::string figure = verdict("max abs(e - e_oracle)", worst, bound);
    if (method == Method::verlet) {
      EXPECT_LT(worst_finest, 2.0);
      figure += "; " + verdict("max omega0 h at the finest level used", worst_finest, 2);
    }
    rows.push_back({"head-on pair, zeta = 0.1", k_range + "; dt_base 1 ms, levels -20 .. 0, tolerance 1e-6",
                    std::string(method_name(method)) + " / doubling", outcome_count(bounded, static_cast<int>(ks.size())) + ", adapted",
                    figure});
  }
  publish_section(1, "Stiffness 1e2 .. 1e9 N/m", rows);
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, MassRatiosUpTo1e20AndInfiniteMass) {
  std::vector<TableRow> rows;
  for (Method method : {Method::verlet, Method::exact}) {
    const Real e_bound = method == Method::exact ? 1e-9 : kRestitutionC * 0.05;
    Real worst_e = 0, worst_p = 0;
    int bounded = 0, total = 0;
    for (int decade = 0; decade <= 20; decade += 2) {
      const LightOnHeavy r = light_on(method, std::pow(10.0, decade) * light_m, false);
      expect_sound(r.audit);
      worst_e = std::max(worst_e, std::abs(r.restitution - restitution_oracle(light_zeta, Separation::force_zero)));
      worst_p = std::max(worst_p, r.momentum_error / momentum_budget(r.particle_steps));
      bounded += r.audit.outcome == Outcome::bounded;
      ++total;
    }
    EXPECT_LE(worst_e, e_bound) << method_name(method);
    EXPECT_LE(worst_p, 1.0) << method_name(method);
    rows.push_back({"10 g sphere on a sphere of M = m .. 1e20 m", "M/m = 1e0, 1e2, .. 1e20; k = 1e4, zeta = 0.1, v = 0.1 m/s",
                    std::string(method_name(method)) + " / fixed", outcome_count(bounded, total),
                    verdict("max abs(e - e_oracle)", worst_e, e_bound) + "; " +
                        verdict("momentum change / round-off budget 4 eps sqrt(steps)", worst_p, 1)});
    const LightOnHeavy wall = light_on(method, 0, true);
    const LightOnHeavy heavy = light_on(method, 1e20, false);
    const LightOnHeavy immovable = light_on(method, std::numeric_limits<Real>::infinity(), false);
    const Real diff = std::max(std::abs(heavy.light_velocity - wall.light_velocity),
                               std::abs(immovable.light_velocity - wall.light_velocity)) / light_v;
    EXPECT_LE(diff, 1e-12);
    EXPECT_EQ(immovable.heavy_shift, 0.0);
    rows.push_back({"same bounce off 1e20 kg, inverse mass 0 and a wall", "m* = 1/(1/m + 1e-20) = m",
                    std::string(method_name(method)) + " / fixed",
                    outcome_count((wall.audit.outcome == Outcome::bounded) + (heavy.audit.outcome == Outcome::bounded) +
                                      (immovable.audit.outcome == Outcome::bounded), 3),
                    verdict("max abs(v_out - v_out,wall) / v", diff, 1e-12) +
                        fmt("; infinite mass moved %.3g m", immovable.heavy_shift)});
  }
  publish_section(2, "Mass ratios up to 1e20 and infinite mass", rows);
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, ReducedMassOf1e9Kg) {
  std::vector<TableRow> rows;
  const Real r = 1e-4, e = restitution_oracle(light_zeta, Separation::force_zero);
  for (Method method : {Method::verlet, Method::exact}) {
    Real worst = 0, worst_p = 0;
    int bounded = 0, total = 0;
    for (int decade = -2; decade <= 9; ++decade)
      for (bool wall : {false, true}) {
        const Real k = std::pow(10.0, decade), m = wall ? 1e-9 : 2e-9, omega0 = std::sqrt(k / 1e-9);
        const Real v = 0.01 * omega0 * r, gap = 1e-3 * r, dt = (method == Method::exact ? 3.0 : 0.05) / omega0;
        const Damping d{DampingKind::damping_ratio, light_zeta};
        World w(wall ? wall_impact(method, k, d, dt, r, m, v, gap) : pair_impact(method, k, d, dt, r, m, m, v, gap));
        const AuditResult a = run_audited(w, static_cast<long>(std::ceil((gap / v + 10 / omega0) / dt)) + 5);
        expect_sound(a);
        const Real restitution = wall ? w.velocity(0).x() / v : pair_restitution(w, v);
        worst = std::max(worst, std::abs(restitution - e));
        if (!wall)
          worst_p = std::max(worst_p, std::abs(w.linear_momentum().x() - m * v) / (m * v) /
                                          momentum_budget(w.counters().particle_steps));
        bounded += a.outcome == Outcome::bounded;
        ++total;
      }
    const Real bound = method == Method::exact ? 1e-9 : kRestitutionC * 0.05;
    EXPECT_LE(worst, bound);
    EXPECT_LE(worst_p, 1.0);
    rows.push_back({"m* = 1e-9 kg pair and on a wall", "k = 1e-2 .. 1e9 N/m (omega0 3e3 .. 1e9 1/s), delta_max = 0.01 R, zeta = 0.1",
                    std::string(method_name(method)) + (method == Method::exact ? " / fixed, omega0 h = 3" : " / fixed, omega0 h = 0.05"),
                    outcome_count(bounded, total),
                    verdict("max abs(e - e_oracle)", worst, bound) + "; " + verdict("momentum / budget", worst_p, 1)});
  }
  publish_section(3, "Reduced mass 1e-9 kg", rows);
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, DampingRatiosFrom0To1e3) {
  std::vector<TableRow> rows;
  const std::vector<Real> zetas{0.0,     1e-3,     0.5, 1 - 1e-4, 1 - 1e-8, 1 - 1e-12, 1.0,
                                1 + 1e-12, 1 + 1e-8, 1 + 1e-4, 2.0,      10.0,      1e3};
  const std::string zeta_list = "zeta = 0, 1e-3, 0.5, 1 -+ 1e-4, 1e-8, 1e-12, 1, 2, 10, 1e3";
  Real worst_fz = 0, worst_ov = 0, worst_continuity = 0, max_e = 0;
  int bounded = 0, total = 0;
  for (Real zeta : zetas) {
    const WallDamped fz = damped_on_wall(Method::exact, zeta, Separation::force_zero, 0.7);
    const WallDamped ov = damped_on_wall(Method::exact, zeta, Separation::overlap, 0.7);
    expect_sound(fz.audit);
    expect_sound(ov.audit);
    const Real e = restitution_oracle(zeta, Separation::force_zero);
    worst_fz = std::max(worst_fz, std::abs(fz.restitution - e) / (1e-9 * e + 1e-15));
    max_e = std::max(max_e, fz.restitution);
    // Overlap convention: released before omega0 t = 200 (zeta well below 1): the overlap
    // restitution; still in contact then: the closed-form rate.
    if (contact_time_oracle(zeta, Separation::overlap) < 190) {
      worst_ov = std::max(worst_ov, std::abs(ov.restitution - restitution_oracle(zeta, Separation::overlap)));
    } else {
      worst_ov = std::max(worst_ov, ov.rate_error);
    }
    if (std::abs(zeta - 1) <= 1e-8) worst_continuity = std::max(worst_continuity, std::abs(fz.restitution - std::exp(-2.0)));
    bounded += (fz.audit.outcome == Outcome::bounded) + (ov.audit.outcome == Outcome::bounded);
    total += 2;
  }
  EXPECT_LE(worst_fz, 1.0);
  EXPECT_LE(worst_ov, 1e-9);
  EXPECT_LE(worst_continuity, 1e-7);
  EXPECT_LE(max_e, 1.0 + 1e-12);
  EXPECT_EQ(bounded, total);
  const std::string params = zeta_list + "; wall, omega0 = 1e3 1/s, omega0 h = 0.7";
  rows.push_back({"force-zero restitution", params, "exact / fixed", outcome_count(bounded, total),
                  verdict("max abs(e - e_oracle) / (1e-9 e + 1e-15)", worst_fz, 1) + fmt("; max e %.15g", max_e)});
  rows.push_back({"continuity at critical damping", "zeta = 1, 1 -+ 1e-12, 1 -+ 1e-8", "exact / fixed", "bounded",
                  verdict("max abs(e - e^-2)", worst_continuity, 1e-7)});
  rows.push_back({"overlap convention", params + "; released: restitution, still in contact at omega0 t = 200 (zeta >= 1 - 1e-4): "
                  "closed-form rate", "exact / fixed", "bounded",
                  verdict("max abs(e - e_oracle) or abs(delta' - closed form) / v", worst_ov, 1e-9)});
  // Verlet at omega0 h = 0.05 up to zeta = 10 (below the damped limit 2 (sqrt(1 + zeta^2) - zeta)).
  {
    Real worst = 0;
    int ok = 0, n = 0;
    for (Real zeta : zetas) {
      if (zeta > 10) continue;
      const WallDamped fz = damped_on_wall(Method::verlet, zeta, Separation::force_zero, 0.05);
      expect_sound(fz.audit);
      worst = std::max(worst, std::abs(fz.restitution - restitution_oracle(zeta, Separation::force_zero)) / 0.05);
      ok += fz.audit.outcome == Outcome::bounded;
      ++n;
    }
    EXPECT_LE(worst, kRestitutionC);
    EXPECT_EQ(ok, n);
    rows.push_back({"force-zero restitution", "zeta = 0 .. 10 (12 values); omega0 h = 0.05", "verlet / fixed", outcome_count(ok, n),
                    verdict("max abs(e - e_oracle) / (omega0 h)", worst, kRestitutionC)});
  }
  for (Real w0h : {5e-4, 1e-3, 2e-3, 0.05}) {
    const WallDamped fz = damped_on_wall(Method::verlet, 1e3, Separation::force_zero, w0h);
    expect_sound(fz.audit);
    const bool within = w0h < 2 * (std::sqrt(1 + 1e6) - 1e3);
    if (within) {
      EXPECT_EQ(fz.audit.outcome, Outcome::bounded);
      EXPECT_LE(fz.restitution, 1.0);
      EXPECT_NEAR(fz.restitution, restitution_oracle(1e3, Separation::force_zero), kRestitutionC * w0h);
    }
    rows.push_back({"zeta = 1e3", fmt("omega0 h = %g (damped limit 1e-3)", w0h), "verlet / fixed", outcome_name(fz.audit.outcome),
                    fmt("e = %.4g (oracle 2.5e-7); ", fz.restitution) +
                        (sound(fz.audit) ? "no NaN, no unflagged growth (ok)" : "NaN or unflagged growth (FAIL)")});
  }
  publish_section(4, "Damping ratios 0 .. 1e3", rows);
}

// ---------------------------------------------------------------------------------------------

void cundall_section(Control control, int order, const char* title) {
  std::vector<TableRow> rows;
  for (CundallScene scene : {CundallScene::pair, CundallScene::walls, CundallScene::packing})
    for (Method method : {Method::verlet, Method::exact})
      for (Real f : cundall_factors) {
        const Stepper s{method, control};
        SCOPED_TRACE(::testing::Message() << stepper_name(s) << ", " << scene_name(scene) << ", f " << f);
        const long intervals = control == Control::fixed ? (scene == CundallScene::pair ? 200 : 5000)
                                                         : (scene == CundallScene::pair ? 200 : 300);
        const CundallRun r = run_cundall(scene, s, f, intervals);
        expect_sound(r.audit);
        std::string figure = fmt("max rise %.3g E0, books %.3g; ", r.audit.max_rise, r.audit.max_book_error);
        figure += sound(r.audit) ? "no NaN, no unflagged growth (ok)" : "NaN or unflagged growth (FAIL)";
        if (control == Control::doubling) {
          EXPECT_EQ(r.audit.outcome, Outcome::bounded);
          EXPECT_LE(r.audit.max_change, 3e-2);
          figure = verdict("max abs(E - E0) / E0", r.audit.max_change, 3e-2);
          if (method == Method::verlet) {
            EXPECT_LT(r.omega_h_finest, 2.0);
            figure += "; " + verdict("omega h finest", r.omega_h_finest, 2);
          }
        }
        if (scene == CundallScene::pair && method == Method::exact) {
          EXPECT_NEAR(r.restitution, 1.0, 1e-9);
          figure += "; " + verdict("abs(e - 1)", std::abs(r.restitution - 1), 1e-9);
        }
        rows.push_back({scene_name(scene),
                        fmt(scene == CundallScene::packing ? "f = %g: dt = f x 2 / omega_max (docs/physics.md 4.2 bound), omega h = %.3g"
                                                           : "f = %g: dt = f x 2 sqrt(m*/k), omega h = %.3g",
                            f, r.omega_h) +
                            (control == Control::doubling ? ", levels -12 .. 0, tol 1e-4" : ""),
                        stepper_name(s),
                        std::string(outcome_name(r.audit.outcome)) + " after " + std::to_string(r.audit.intervals) + " intervals" +
                            (control == Control::doubling ? fmt(", adapted to omega h %.2g", r.omega_h_finest) : ""),
                        figure});
      }
  publish_section(order, title, rows);
}

TEST(ExtremesLong, CundallLimitFixedStep) {
  cundall_section(Control::fixed, 5, "Beyond the Cundall limit, fixed step");
}

TEST(ExtremesLong, CundallLimitDoubling) {
  cundall_section(Control::doubling, 6, "Beyond the Cundall limit, step doubling");
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, TolerancesFrom1e12To1e1) {
  // The damped wall impact under doubling, 8 onset phases per tolerance, every decade. Above the
  // round-off floor (down to 1e-6 here) the error must fall monotonically, within 5% (two tolerances
  // may take the same steps through the onset); below, steps reach level_min, are force-accepted,
  // and the error may not exceed 1e-6's or C omega0 h_min.
  std::vector<TableRow> rows;
  const Real omega_h_min = 4 * std::ldexp(1.0, tol_level_min);
  Real previous_error = std::numeric_limits<Real>::infinity(), error_at_1e6 = 0;
  std::uint64_t previous_forced = 0;
  for (int decade = -1; decade >= -12; --decade) {
    const Real tol = std::pow(10.0, decade);
    const ToleranceRun r = tolerance_run(Method::verlet, tol);
    EXPECT_EQ(r.audit.intervals, tol_intervals);
    expect_sound(r.audit);
    std::string figure;
    if (decade >= -6) {
      EXPECT_LE(r.error, 1.05 * previous_error) << "tolerance " << tol;
      figure = decade == -1 ? std::string("the loosest tolerance")
                            : verdict("max abs(e - e_oracle) / previous decade's", r.error / previous_error, 1.05);
      if (decade == -6) error_at_1e6 = r.error;
    } else {
      const Real bound = std::max(error_at_1e6, kRestitutionC * omega_h_min);
      EXPECT_LE(r.error, bound) << "tolerance " << tol;
      figure = verdict("max abs(e - e_oracle)", r.error, bound);
    }
    EXPECT_GE(r.forced, previous_forced);
    if (decade == -1) {
      EXPECT_EQ(r.forced, 0u);
    }
    if (decade == -12) {
      EXPECT_GT(r.forced, 0u);
    }
    previous_error = r.error;
    previous_forced = r.forced;
    rows.push_back({"damped wall impact (zeta = 0.1), 8 onset phases", fmt("tolerance 1e%g; dt_base 4 / omega0, levels -16 .. 0", decade),
                    "verlet / doubling",
                    std::string(outcome_name(r.audit.outcome)) +
                        fmt(", terminated: %.0f particle-steps, ", static_cast<double>(r.particle_steps)) + std::to_string(r.forced) +
                        " forced",
                    fmt("max abs(e - e_oracle) = %.3g; ", r.error) + figure});
  }
  {
    Real worst = 0;
    for (int decade = -1; decade >= -12; --decade) worst = std::max(worst, tolerance_run(Method::exact, std::pow(10.0, decade)).error);
    EXPECT_LE(worst, 1e-9);
    rows.push_back({"damped wall impact (zeta = 0.1)", "tolerance 1e-1 .. 1e-12, every decade", "exact / doubling",
                    "bounded, terminated", verdict("max abs(e - e_oracle)", worst, 1e-9)});
  }
  for (Method method : {Method::verlet, Method::exact})
    for (Real tol : {1e-12, 1e-6, 1e-1}) {
      WorldConfig c = packing_config(method);
      Real omega_max = 0;
      {
        const World probe(c);
        omega_max = omega_max_bound(probe);
      }
      set_doubling(c, 0.3 / omega_max, -4, 0, tol);
      World w(c);
      const AuditResult a = run_audited(w, 20);
      EXPECT_EQ(a.intervals, 20);
      expect_sound(a);
      const std::uint64_t bound = 3u * 36u * 16u * 5u * 20u;
      EXPECT_LE(w.counters().particle_steps, bound);
      if (tol == 1e-12) {
        EXPECT_GT(w.counters().forced_steps, 0u);
      }
      rows.push_back({"36-disc packing", fmt("tolerance %g; levels -4 .. 0, 20 intervals", tol),
                      std::string(method_name(method)) + " / doubling",
                      std::string(outcome_name(a.outcome)) + ", terminated, " + std::to_string(w.counters().forced_steps) + " forced",
                      verdict("particle-steps / (3 trials x levels x ticks)", static_cast<Real>(w.counters().particle_steps) / bound, 1)});
    }
  publish_section(7, "Tolerances 1e-12 .. 1e-1", rows);
}

// ---------------------------------------------------------------------------------------------

struct DeepSummary {
  int through = 0, flagged = 0, bounded = 0, cases = 0;
  int verlet_unflagged = 0, exact_unflagged = 0, silent_through = 0;  // silent: passed through unflagged
  Real worst_e = 0;        // max |e - 1| over the configurations that bounced, relative to their bound
  Real worst_overlap = 0;  // max overlap seen / delta_max
};

DeepSummary deep_sweep(Target target, Real ratio) {
  DeepSummary s;
  for (const DeepConfig& config : deep_configs) {
    const Impact r = deep_impact(target, config, ratio);
    expect_sound(r.audit);
    ++s.cases;
    s.through += r.end.passed_through();
    s.flagged += r.audit.outcome != Outcome::bounded;
    s.bounded += r.audit.outcome == Outcome::bounded;
    const bool exact = config.stepper.method == Method::exact;
    const bool unflagged = r.audit.outcome == Outcome::bounded;
    (exact ? s.exact_unflagged : s.verlet_unflagged) += unflagged;
    s.silent_through += unflagged && r.end.passed_through();
    const Real tol = exact ? 1e-9
                     : config.stepper.control == Control::doubling ? 1e-3
                                                                    : kUndampedC * config.omega_dt * config.omega_dt;
    if (!r.end.passed_through()) s.worst_e = std::max(s.worst_e, std::abs(r.end.restitution - 1) / tol);
    s.worst_overlap = std::max(s.worst_overlap, r.audit.max_overlap / ratio);
  }
  return s;
}

const char* deep_steppers = "verlet fixed 0.02; exact fixed 0.02, 1, 10; verlet doubling 1; exact doubling 10 (omega0 dt)";

TEST(ExtremesLong, ImpactsWithOverlapUpToTheDiameter) {
  std::vector<TableRow> rows;
  for (Target target : {Target::wall, Target::particle})
    for (Real ratio : {0.1, 0.5, 1.0, 1.5, 1.9}) {
      const DeepSummary s = deep_sweep(target, ratio);
      EXPECT_EQ(s.through, 0) << target_name(target) << " " << ratio;
      EXPECT_LE(s.worst_e, 1.0);
      EXPECT_LE(s.worst_overlap, 1.0 + 1e-2);
      rows.push_back({std::string("undamped impact on a ") + target_name(target),
                      fmt("v / omega0 = %g R, k = 1e3, 10 g, R = 1 cm", ratio), deep_steppers,
                      std::to_string(s.cases - s.through) + " of " + std::to_string(s.cases) + " on their side; " +
                          std::to_string(s.flagged) + " flagged (overlap > 0.5 R seen), " + std::to_string(s.bounded) + " bounded",
                      verdict("max abs(e - 1) / bound", s.worst_e, 1) + "; " +
                          verdict("max overlap seen / delta_max", s.worst_overlap, 1.01)});
    }
  publish_section(8, "Overlap comparable to the radius", rows);
}

TEST(ExtremesLong, ImpactsWithOverlapBeyondTheDiameter) {
  // Every stepper flags every such impact: Verlet watches the overlap every step or round, the
  // exact stepper's flows report the deepest overlap inside a step.
  std::vector<TableRow> rows;
  for (Target target : {Target::wall, Target::particle})
    for (Real ratio : {2.5, 4.0}) {
      const DeepSummary s = deep_sweep(target, ratio);
      EXPECT_EQ(s.verlet_unflagged + s.exact_unflagged, 0) << target_name(target) << ", v / omega0 = " << ratio << " R";
      rows.push_back({std::string("undamped impact on a ") + target_name(target),
                      fmt("v / omega0 = %g R (the law's overlap beyond 2R)", ratio), deep_steppers,
                      std::to_string(s.through) + " of " + std::to_string(s.cases) + " go on through after the flag; " +
                          std::to_string(s.cases - s.flagged) + " never flagged",
                      verdict("unflagged", s.verlet_unflagged + s.exact_unflagged, 0) + "; " +
                          verdict("silent pass-throughs", s.silent_through, 0)});
    }
  publish_section(9, "Overlap beyond the diameter", rows);
}

const std::vector<Real> tunnel_diameters{0.5, 1.5, 3.0, 30.0, 300.0};

TEST(ExtremesLong, StepsLongerThanTheParticleExactAndDoubling) {
  std::vector<TableRow> rows;
  for (Target target : {Target::wall, Target::particle})
    for (Real diameters : tunnel_diameters) {
      int through = 0, bounded = 0, n = 0;
      Real worst_e = 0, worst_overlap = 0;
      for (Stepper s : {Stepper{Method::exact, Control::fixed}, Stepper{Method::exact, Control::doubling},
                        Stepper{Method::verlet, Control::doubling}}) {
        const Impact r = tunnelling_impact(target, s, diameters);
        expect_sound(r.audit);
        through += r.end.passed_through();
        bounded += r.audit.outcome == Outcome::bounded;
        ++n;
        worst_e = std::max(worst_e, std::abs(r.end.restitution - 1) / (s.method == Method::exact ? 1e-9 : 1e-3));
        worst_overlap = std::max(worst_overlap, r.audit.max_overlap / 0.1);
      }
      EXPECT_EQ(through, 0);
      EXPECT_EQ(bounded, n);
      EXPECT_LE(worst_e, 1.0);
      EXPECT_LE(worst_overlap, 1.01);
      rows.push_back({std::string("undamped impact on a ") + target_name(target),
                      fmt("v dt = %g x 2R (v = 10 m/s, delta_max = 0.1 R)", diameters),
                      "exact fixed, exact doubling, verlet doubling",
                      std::to_string(n - through) + " of " + std::to_string(n) + " on their side, " + outcome_count(bounded, n),
                      verdict("max abs(e - 1) / bound (1e-9 exact, 1e-3 doubling)", worst_e, 1) + "; " +
                          verdict("overlap / delta_max", worst_overlap, 1.01)});
    }
  publish_section(10, "Steps longer than the particle (tunnelling), exact and doubling", rows);
}

TEST(ExtremesLong, StepsLongerThanTheParticleVerletFixed) {
  // As VerletAtAFixedStepLongerThanTheParticleDoesNotTunnelSilently in the default suite.
  std::vector<TableRow> rows;
  for (Target target : {Target::wall, Target::particle})
    for (Real diameters : tunnel_diameters) {
      const Impact r = tunnelling_impact(target, {Method::verlet, Control::fixed}, diameters);
      expect_sound(r.audit);
      const bool quiet = r.end.passed_through() && r.audit.outcome == Outcome::bounded;
      EXPECT_FALSE(quiet) << target_name(target) << ", v dt = " << diameters << " x 2R";
      rows.push_back({std::string("undamped impact on a ") + target_name(target),
                      fmt("v dt = %g x 2R (omega0 dt = %g)", diameters, diameters * 2 * 0.01 / 10 * 1e4 / (target == Target::wall ? 1 : std::sqrt(0.5))),
                      "verlet / fixed",
                      std::string(r.end.passed_through() ? "passed through" : "on its side") + ", " + outcome_name(r.audit.outcome) +
                          fmt(" (h v / R = %.3g)", r.audit.max_travel),
                      quiet ? "silent pass-through (FAIL)" : std::string("no silent pass-through (ok)")});
    }
  publish_section(11, "Steps longer than the particle, Verlet at a fixed step", rows);
}

// ---------------------------------------------------------------------------------------------

TEST(ExtremesLong, ThirtyAndFortyLevels) {
  std::vector<TableRow> rows;
  struct Case {
    Method method;
    int levels;
    long intervals;
  };
  for (const Case& c : {Case{Method::verlet, 30, 20'000}, Case{Method::verlet, 40, 2'000}, Case{Method::exact, 30, 1'000'000},
                        Case{Method::exact, 40, 100'000}}) {
    SCOPED_TRACE(::testing::Message() << method_name(c.method) << " " << c.levels);
    const LevelsRun r = levels_run(c.method, c.levels, c.intervals);
    EXPECT_EQ(r.audit.intervals, c.intervals);
    EXPECT_EQ(r.audit.non_finite_ok, 0);
    EXPECT_TRUE(r.clock_exact);
    EXPECT_TRUE(r.ticks_covered);
    const Real free_bound = 4.0 * static_cast<Real>(c.intervals) * kEps * (10 + 0.45 * c.intervals * 0x1p-12);
    EXPECT_LE(r.free_error, free_bound);
    const Real energy_bound = c.method == Method::exact ? 1e-10 * std::sqrt(c.intervals / 200.0) : 1e-2;
    EXPECT_LE(r.energy_change, energy_bound);
    EXPECT_EQ(r.forced, 0u);
    rows.push_back({"bouncing particle + free particle", fmt("level_max - level_min = %g, %g sync intervals", c.levels, static_cast<double>(c.intervals)),
                    std::string(method_name(c.method)) + " / doubling, tolerance 1e-6",
                    std::string(outcome_name(r.audit.outcome)) + fmt(", finest level used %g", r.finest),
                    std::string(r.clock_exact ? "time = n T exactly, " : "time off (FAIL), ") +
                        (r.ticks_covered ? "ticks covered exactly; " : "ticks not covered (FAIL); ") +
                        verdict("free-flight error [m]", r.free_error, free_bound) + "; " +
                        verdict("abs(E - E0) / E0", r.energy_change, energy_bound)});
  }
  publish_section(12, "30 and 40 levels", rows);
}

// ---------------------------------------------------------------------------------------------
// 1e7 steps: a 10 g, 1 cm sphere (k = 1e6, omega0 = 1e4 1/s, v = 1 m/s, delta_max = 1e-4 m) bouncing
// between two 1e20 kg spheres, undamped. Everything is finite, so the total momentum (heavy spheres
// included, computed here: linear_momentum() leaves out masses above 1e15 kg) is conserved; the
// energy is the light sphere's kinetic and elastic energy plus the heavy spheres' kinetic energy.

struct CagedRun {
  Real max_error = 0;            // max |E - E0| / E0 (sampled every 10 steps)
  Real first_mean = 0, last_mean = 0;  // mean (E - E0) / E0 over the first and last tenth
  Real momentum_error = 0;       // |P - P0| / (m v)
  Real largest_momentum = 0;     // max |p| of one body at the end / (m v)
  Real dissipated = 0;           // World::dissipated_energy() / E0
  long contacts = 0;
  bool all_ok = true;
  double seconds = 0;
};

CagedRun caged(Method method, Real w0h, long steps) {
  const Real k = 1e6, m = 0.01, r = 0.01, v = 1, heavy = 1e20, omega0 = std::sqrt(k / m), reach = v / omega0;
  WorldConfig c = base_config(w0h / omega0);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = k;
  c.particles.push_back(particle(Vec3(-2 * r - 3 * reach, 0, 0), Vec3::Zero(), r, heavy));
  c.particles.push_back(particle(Vec3::Zero(), Vec3(v, 0, 0), r, m));
  c.particles.push_back(particle(Vec3(2 * r + 3 * reach * 1.2345678, 0, 0), Vec3::Zero(), r, heavy));
  World w(c);
  const auto energy = [&w] {
    const Energies e = w.energies();
    const State& s = w.state();
    Real heavy_kinetic = 0;
    for (std::size_t q = 0; q < s.size(); ++q)
      if (!is_audited(s.inv_mass[q])) heavy_kinetic += 0.5 * s.velocity[q].squaredNorm() / s.inv_mass[q];
    return e.kinetic + e.elastic + heavy_kinetic;
  };
  const auto momentum = [&w] {
    Real p = 0;
    const State& s = w.state();
    for (std::size_t q = 0; q < s.size(); ++q) p += s.velocity[q].x() / s.inv_mass[q];
    return p;
  };
  const Real e0 = energy(), p0 = momentum();
  CagedRun out;
  const auto start = std::chrono::steady_clock::now();
  const long samples = steps / 10, tenth = samples / 10;
  bool touching = false;
  for (long q = 0; q < samples; ++q) {
    for (int s = 0; s < 10; ++s) {
      out.all_ok = out.all_ok && w.advance_sync_interval() == StepStatus::ok;
      const bool now = w.pair_contacts().size() > 0;
      out.contacts += now && !touching;
      touching = now;
    }
    const Real d = (energy() - e0) / e0;
    out.max_error = std::max(out.max_error, std::abs(d));
    if (q < tenth) out.first_mean += d / static_cast<Real>(tenth);
    if (q >= samples - tenth) out.last_mean += d / static_cast<Real>(tenth);
  }
  out.all_ok = out.all_ok && state_finite(w);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  out.momentum_error = std::abs(momentum() - p0) / (m * v);
  for (std::size_t q = 0; q < w.state().size(); ++q)
    out.largest_momentum = std::max(out.largest_momentum, std::abs(w.state().velocity[q].x() / w.state().inv_mass[q]) / (m * v));
  out.dissipated = w.dissipated_energy() / e0;
  std::printf("caged %s, omega0 h = %g, %ld steps (%.1f s): %ld contacts, max |dE| %.3e E0, first/last tenth %.3e / %.3e, "
              "|dP| %.3e m v (largest body momentum %.3e m v), books: dissipated %.3e E0\n",
              method_name(method), w0h, steps, out.seconds, out.contacts, out.max_error, out.first_mean, out.last_mean,
              out.momentum_error, out.largest_momentum, out.dissipated);
  return out;
}

TEST(ExtremesLong, TenMillionStepsOfAnUndampedBounceKeepEnergyAndMomentum) {
  std::vector<TableRow> rows;
  const long steps = 10'000'000;
  const std::string scene = "10 g sphere between two 1e20 kg spheres, undamped";
  {
    const Real w0h = 0.1, w2 = w0h * w0h;
    const CagedRun r = caged(Method::verlet, w0h, steps);
    EXPECT_TRUE(r.all_ok);
    // Bounds of contact_scenes.h (expect_no_drift): |dE| <= 0.5 (omega0 h)^2 E0 (shadow energy inside
    // a contact plus the zero-mean kink errors at onset and separation); no drift: the last tenth's
    // mean within 0.05 (omega0 h)^2 of the first tenth's.
    EXPECT_LE(r.max_error, 0.5 * w2);
    EXPECT_LE(std::abs(r.last_mean - r.first_mean), 0.05 * w2);
    // Momentum: each step rounds each body's velocity, the heavy ones' momenta growing to ~contacts x
    // m v: round-off budget 4 eps sqrt(3 steps) x the largest momentum of one body.
    const Real p_bound = momentum_budget(3 * static_cast<std::uint64_t>(steps)) * r.largest_momentum;
    EXPECT_LE(r.momentum_error, p_bound);
    rows.push_back({scene, "omega0 h = 0.1, 1e7 steps, " + std::to_string(r.contacts) + " contacts", "verlet / fixed",
                    r.all_ok ? "bounded" : "a step not ok (FAIL)",
                    verdict("max abs(E - E0) / E0", r.max_error, 0.5 * w2) + "; " +
                        verdict("drift (last - first tenth)", std::abs(r.last_mean - r.first_mean), 0.05 * w2) + "; " +
                        verdict("abs(P - P0) / (m v)", r.momentum_error, p_bound)});
  }
  {
    const CagedRun r = caged(Method::exact, 0.7, steps);
    EXPECT_TRUE(r.all_ok);
    // Exact flows: only round-off, a random walk. Each contact's energy carries ~eps L / delta_max of
    // relative error (the overlap is a difference of positions of size L = 2R + 3.7 delta_max).
    const Real reach = 1e-4, length = 0.02 + 3.7 * reach;
    const Real e_bound = 8 * kEps * (length / reach) * std::sqrt(static_cast<Real>(steps));
    EXPECT_LE(r.max_error, e_bound);
    const Real p_bound = momentum_budget(3 * static_cast<std::uint64_t>(steps)) * r.largest_momentum;
    EXPECT_LE(r.momentum_error, p_bound);
    EXPECT_LE(std::abs(r.dissipated), e_bound);
    rows.push_back({scene, "omega0 h = 0.7, 1e7 steps, " + std::to_string(r.contacts) + " contacts", "exact / fixed",
                    r.all_ok ? "bounded" : "a step not ok (FAIL)",
                    verdict("max abs(E - E0) / E0", r.max_error, e_bound) + " (8 eps L/delta sqrt(steps)); " +
                        verdict("abs(P - P0) / (m v)", r.momentum_error, p_bound) + "; " +
                        verdict("books: abs(dissipated) / E0", std::abs(r.dissipated), e_bound)});
  }
  publish_section(13, "1e7 steps: energy and momentum drift", rows);
}

TEST(ExtremesLong, EnergyBooksOfUndampedVerletRuns) {
  std::vector<TableRow> rows;
  for (bool pair : {false, true})
    for (Real w0h : {0.03, 0.1}) {
      const long steps = 1'000'000;
      const BooksRun r = books_run(Method::verlet, w0h, steps, pair);
      // As in the default suite's EnergyBooksOfAnUndampedVerletRunShowNoDissipation.
      const Real bound = 0.5 * w0h * w0h, round_off = 1e-9;
      if (!pair) {
        EXPECT_LE(r.energy_error, bound);
      }
      EXPECT_LE(std::abs(r.dissipated), round_off);
      EXPECT_LE(std::abs(r.book_error), r.energy_error + round_off);
      rows.push_back({pair ? "two 1 kg spheres between two walls, undamped" : "1 kg sphere between two walls, undamped",
                      fmt("omega0 h = %g, 1e6 steps, %g contacts", w0h, static_cast<double>(r.contacts)),
                      "verlet / fixed", r.book_error > kGrowthLimit ? "flagged by the books (FAIL)" : "not flagged",
                      (pair ? fmt("abs(E - E0) / E0 %.3g (a random walk over the impacts)", r.energy_error)
                            : verdict("abs(E - E0) / E0", r.energy_error, bound)) + "; " +
                          verdict("books: abs(dissipated) / E0", std::abs(r.dissipated), round_off) + "; " +
                          verdict("abs(balance error) / energy in play", std::abs(r.book_error),
                                  r.energy_error + round_off) + " (at most the energy error)"});
    }
  {
    WorldConfig c = packing_config(Method::verlet);
    Real omega_max = 0;
    {
      const World probe(c);
      omega_max = omega_max_bound(probe);
    }
    c.integrator.dt = 0.3 / omega_max;
    World w(c);
    const Real e0 = w.energies().total();
    const AuditResult a = run_audited(w, 100'000, false);
    const Real dissipated = w.dissipated_energy() / e0;
    EXPECT_LE(std::abs(dissipated), 3e-2);
    EXPECT_EQ(a.outcome, Outcome::bounded);
    rows.push_back({"36-disc packing, undamped", "omega_max h = 0.3, 1e5 steps", "verlet / fixed", outcome_name(a.outcome),
                    verdict("abs(E - E0) / E0", a.max_change, 3e-2) + "; " +
                        verdict("books: abs(dissipated) / E0", std::abs(dissipated), 3e-2)});
  }
  publish_section(14, "Energy books of undamped Verlet runs", rows);
}

}  // namespace
}  // namespace dem
