// Tests of engine/damping.h: restitution <-> damping ratio <-> contact time of the linear
// spring-dashpot (docs/physics.md 2.2) in both separation conventions.
// Oracles: the verified table of docs/physics.md 2.2, the closed forms of 1.2 re-derived here, and an
// independent method (RK4 integration of the dimensionless damped oscillator with the contact-end
// rule of each convention). Never values copied from the engine.
#include "engine/damping.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace dem {
namespace {

constexpr Separation kOverlap = Separation::overlap;
constexpr Separation kForceZero = Separation::force_zero;
const Real kCriticalRestitution = std::exp(-2.0);  // force-zero e at zeta = 1

// One row of the docs/physics.md 2.2 table (e, zeta and omega0 t_c in both conventions).
struct TableRow {
  Real e;
  Real zeta_overlap, time_overlap;
  Real zeta_force_zero, time_force_zero;
};

const std::vector<TableRow>& table() {
  static const std::vector<TableRow> rows = {
      {0.9, 0.03352, 3.1434, 0.03427, 3.0749},       {0.8, 0.07085, 3.1495, 0.07436, 3.0011},
      {0.5, 0.21545, 3.2172, 0.25528, 2.7153},       {0.3, 0.35786, 3.3644, 0.49724, 2.4213},
      {0.135335, 0.53703, 3.7242, 1.00000, 2.0000},  {0.1, 0.59116, 3.8951, 1.24319, 1.8522},
  };
  return rows;
}

// Half a unit in the last printed digit of the table (5 decimals for zeta, 4 for omega0 t_c).
constexpr Real kZetaDigits = 0.5e-5 + 1e-12;
constexpr Real kTimeDigits = 0.5e-4 + 1e-12;

// Independent method: integrate delta'' + 2 zeta delta' + delta = 0 (omega0 = 1) from delta = 0,
// delta' = 1 with classical RK4 and end the contact by the convention's rule (delta = 0, or
// delta + 2 zeta delta' = 0), located by a cubic Hermite root between steps.
struct Rebound {
  Real time;         // omega0 t_c
  Real restitution;  // -delta'(t_c) / delta'(0)
};

Rebound integrate_contact(Real zeta, Separation separation) {
  const Real h = 1e-4;
  auto accel = [zeta](Real d, Real v) { return -2 * zeta * v - d; };
  auto end_function = [&](Real d, Real v) { return separation == kOverlap ? d : d + 2 * zeta * v; };
  Real d = 0, v = 1, t = 0;
  Real g_prev = end_function(d, v);  // 2 zeta > 0 at t = 0 for force-zero, 0 for overlap: step first
  for (int step = 0; step < 10'000'000; ++step) {
    const Real k1d = v, k1v = accel(d, v);
    const Real k2d = v + 0.5 * h * k1v, k2v = accel(d + 0.5 * h * k1d, v + 0.5 * h * k1v);
    const Real k3d = v + 0.5 * h * k2v, k3v = accel(d + 0.5 * h * k2d, v + 0.5 * h * k2v);
    const Real k4d = v + h * k3v, k4v = accel(d + h * k3d, v + h * k3v);
    const Real d1 = d + h / 6 * (k1d + 2 * k2d + 2 * k3d + k4d);
    const Real v1 = v + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
    const Real g1 = end_function(d1, v1);
    if (step > 0 && g_prev > 0 && g1 <= 0) {
      // Bisect on the cubic Hermite interpolant of (d, v) over the step.
      Real lo = 0, hi = 1, v_root = v1;
      for (int it = 0; it < 60; ++it) {
        const Real s = 0.5 * (lo + hi);
        const Real h00 = 2 * s * s * s - 3 * s * s + 1, h10 = s * s * s - 2 * s * s + s;
        const Real h01 = -2 * s * s * s + 3 * s * s, h11 = s * s * s - s * s;
        const Real ds = h00 * d + h10 * h * v + h01 * d1 + h11 * h * v1;
        const Real a0 = accel(d, v), a1 = accel(d1, v1);
        const Real vs = h00 * v + h10 * h * a0 + h01 * v1 + h11 * h * a1;
        if (end_function(ds, vs) > 0) lo = s;
        else hi = s;
        v_root = vs;
      }
      return {t + 0.5 * (lo + hi) * h, -v_root};
    }
    d = d1;
    v = v1;
    t += h;
    g_prev = g1;
  }
  return {std::numeric_limits<Real>::infinity(), 0};
}

TEST(Damping, OverlapConventionMatchesPhysicsTable) {
  for (const TableRow& row : table()) {
    SCOPED_TRACE(row.e);
    EXPECT_NEAR(damping_ratio_from_restitution(row.e, kOverlap), row.zeta_overlap, kZetaDigits);
    EXPECT_NEAR(dimensionless_contact_time(row.zeta_overlap, kOverlap), row.time_overlap, kTimeDigits + 1e-4);
    EXPECT_NEAR(dimensionless_contact_time(damping_ratio_from_restitution(row.e, kOverlap), kOverlap),
                row.time_overlap, kTimeDigits);
  }
}

TEST(Damping, ForceZeroConventionMatchesPhysicsTable) {
  for (const TableRow& row : table()) {
    SCOPED_TRACE(row.e);
    EXPECT_NEAR(damping_ratio_from_restitution(row.e, kForceZero), row.zeta_force_zero, kZetaDigits);
    EXPECT_NEAR(dimensionless_contact_time(damping_ratio_from_restitution(row.e, kForceZero), kForceZero),
                row.time_force_zero, kTimeDigits);
  }
}

TEST(Damping, RestitutionFromTableRatioReproducesTableRestitution) {
  // The table's zeta has 5 decimals; de/dzeta is at most ~3 in magnitude over the table, so e is
  // reproduced to 3 * 0.5e-5 plus the 6-digit rounding of e^-2 in the table.
  for (const TableRow& row : table()) {
    SCOPED_TRACE(row.e);
    EXPECT_NEAR(restitution_from_damping_ratio(row.zeta_overlap, kOverlap), row.e, 2e-5);
    EXPECT_NEAR(restitution_from_damping_ratio(row.zeta_force_zero, kForceZero), row.e, 2e-5);
  }
}

TEST(Damping, ClosedFormsOfBothConventionsHold) {
  // Overlap: e = exp(-zeta pi / sqrt(1 - zeta^2)), t_c omega0 = pi / sqrt(1 - zeta^2).
  // Force-zero: e = exp(-zeta omega0 t_c) in every regime (docs/physics.md 2.2).
  for (Real zeta : {1e-6, 0.01, 0.1, 0.3, 0.6, 0.9, 0.999}) {
    SCOPED_TRACE(zeta);
    const Real wd = std::sqrt(1 - zeta * zeta);
    EXPECT_NEAR(restitution_from_damping_ratio(zeta, kOverlap), std::exp(-zeta * pi / wd), 1e-14);
    EXPECT_NEAR(dimensionless_contact_time(zeta, kOverlap), pi / wd, 1e-12 * pi / wd);
    const Real tc = (pi - 2 * std::atan(zeta / wd)) / wd;
    EXPECT_NEAR(dimensionless_contact_time(zeta, kForceZero), tc, 1e-12 * tc);
  }
  for (Real zeta : {1e-6, 0.1, 0.7, 1.0, 1.3, 3.0, 30.0, 1e3}) {
    SCOPED_TRACE(zeta);
    const Real tc = dimensionless_contact_time(zeta, kForceZero);
    EXPECT_NEAR(restitution_from_damping_ratio(zeta, kForceZero), std::exp(-zeta * tc), 1e-14);
  }
  for (Real zeta : {1.3, 3.0, 30.0}) {  // over-damped: t_c = ln((beta+s)/(beta-s))/s, omega0 = 1
    const Real s = std::sqrt(zeta * zeta - 1);
    EXPECT_NEAR(dimensionless_contact_time(zeta, kForceZero), std::log((zeta + s) / (zeta - s)) / s, 1e-10);
  }
  EXPECT_DOUBLE_EQ(dimensionless_contact_time(1.0, kForceZero), 2.0);
  EXPECT_NEAR(restitution_from_damping_ratio(1.0, kForceZero), kCriticalRestitution, 1e-15);
}

TEST(Damping, BothConventionsAgreeWithDirectIntegrationOfTheOscillator) {
  // RK4 at h = 1e-4 (omega0 = 1): errors ~1e-12 in the state, ~1e-9 in the located end time.
  for (Real zeta : {0.0, 0.05, 0.2, 0.5, 0.8}) {
    SCOPED_TRACE(zeta);
    const Rebound r = integrate_contact(zeta, kOverlap);
    EXPECT_NEAR(dimensionless_contact_time(zeta, kOverlap), r.time, 1e-8);
    EXPECT_NEAR(restitution_from_damping_ratio(zeta, kOverlap), r.restitution, 1e-8);
  }
  for (Real zeta : {0.05, 0.2, 0.5, 0.8, 0.99, 1.0, 1.01, 1.5, 4.0}) {
    SCOPED_TRACE(zeta);
    const Rebound r = integrate_contact(zeta, kForceZero);
    EXPECT_NEAR(dimensionless_contact_time(zeta, kForceZero), r.time, 1e-8);
    EXPECT_NEAR(restitution_from_damping_ratio(zeta, kForceZero), r.restitution, 1e-8);
  }
}

TEST(Damping, RestitutionDecreasesStrictlyWithDampingRatio) {
  for (Separation sep : {kOverlap, kForceZero}) {
    const Real zeta_end = sep == kOverlap ? 0.999 : 1e3;
    Real previous = restitution_from_damping_ratio(0, sep);
    EXPECT_EQ(previous, 1.0);
    for (Real zeta = 1e-4; zeta < zeta_end; zeta *= 1.05) {
      const Real e = restitution_from_damping_ratio(zeta, sep);
      ASSERT_TRUE(std::isfinite(e)) << zeta;
      ASSERT_GT(e, 0.0) << zeta;
      ASSERT_LT(e, previous) << "separation " << static_cast<int>(sep) << " zeta " << zeta;
      previous = e;
    }
  }
}

TEST(Damping, DampingRatioDecreasesStrictlyWithRestitution) {
  for (Separation sep : {kOverlap, kForceZero}) {
    Real previous = std::numeric_limits<Real>::infinity();
    for (Real e = 1e-3; e < 1; e += 1e-3) {
      const Real zeta = damping_ratio_from_restitution(e, sep);
      ASSERT_TRUE(std::isfinite(zeta)) << e;
      ASSERT_LT(zeta, previous) << "separation " << static_cast<int>(sep) << " e " << e;
      previous = zeta;
    }
    EXPECT_EQ(damping_ratio_from_restitution(1.0, sep), 0.0);
  }
}

TEST(Damping, ConversionsRoundTrip) {
  for (Separation sep : {kOverlap, kForceZero}) {
    for (Real e : {1e-4, 0.01, 0.1, 0.135335283, 0.2, 0.5, 0.74408, 0.9, 0.99, 0.999999}) {
      SCOPED_TRACE(e);
      const Real zeta = damping_ratio_from_restitution(e, sep);
      EXPECT_NEAR(restitution_from_damping_ratio(zeta, sep), e, 1e-12 * e);
    }
    const std::vector<Real> zetas = sep == kOverlap ? std::vector<Real>{1e-6, 0.01, 0.1, 0.5, 0.9, 0.99}
                                                    : std::vector<Real>{1e-6, 0.01, 0.1, 0.5, 0.9, 0.999, 1.001,
                                                                        1.5, 10.0, 100.0};
    for (Real zeta : zetas) {
      SCOPED_TRACE(zeta);
      const Real e = restitution_from_damping_ratio(zeta, sep);
      EXPECT_NEAR(damping_ratio_from_restitution(e, sep), zeta, 1e-9 * zeta);
    }
  }
}

TEST(Damping, ForceZeroIsContinuousAcrossCriticalDamping) {
  // Near zeta = 1 both e and omega0 t_c are smooth in zeta with |d/dzeta| < 1 (from the table:
  // e goes 0.3 -> 0.135 over zeta 0.5 -> 1, t_c 2.42 -> 2.00), so within 1e-8 of zeta = 1 they
  // must stay within 1e-8 of e^-2 and 2 (plus round-off).
  for (Real offset : {1e-8, 1e-7, 1e-6, 2e-6, 1e-5}) {
    SCOPED_TRACE(offset);
    for (Real zeta : {1 - offset, 1 + offset}) {
      EXPECT_NEAR(restitution_from_damping_ratio(zeta, kForceZero), kCriticalRestitution, offset + 1e-12);
      EXPECT_NEAR(dimensionless_contact_time(zeta, kForceZero), 2.0, offset + 1e-10);
    }
  }
  EXPECT_NEAR(damping_ratio_from_restitution(kCriticalRestitution, kForceZero), 1.0, 1e-9);
  EXPECT_NEAR(damping_ratio_from_restitution(kCriticalRestitution * (1 + 1e-9), kForceZero), 1.0, 1e-7);
  EXPECT_NEAR(damping_ratio_from_restitution(kCriticalRestitution * (1 - 1e-9), kForceZero), 1.0, 1e-7);
}

TEST(Damping, OverlapConventionHasNoReboundAtOrAboveCriticalDamping) {
  EXPECT_EQ(restitution_from_damping_ratio(1.0, kOverlap), 0.0);
  EXPECT_EQ(restitution_from_damping_ratio(2.0, kOverlap), 0.0);
  EXPECT_TRUE(std::isinf(dimensionless_contact_time(1.0, kOverlap)));
  // Just below critical the overlap e is tiny but positive: exp(-0.999 pi / sqrt(1 - 0.999^2)) = 4.4e-31.
  const Real e = restitution_from_damping_ratio(0.999, kOverlap);
  EXPECT_NEAR(e, std::exp(-0.999 * pi / std::sqrt(1 - 0.999 * 0.999)), 1e-40);
  EXPECT_GT(e, 1e-31);
  EXPECT_LT(e, 1e-30);
}

TEST(Damping, ConventionsAgreeToFirstOrderInDampingRatio) {
  // Both give -ln e = pi zeta + O(zeta^2); their difference is O(zeta^2) (docs/physics.md 2.2).
  for (Real zeta : {1e-3, 1e-4, 1e-5}) {
    const Real lo = -std::log(restitution_from_damping_ratio(zeta, kOverlap));
    const Real lf = -std::log(restitution_from_damping_ratio(zeta, kForceZero));
    EXPECT_NEAR(lo, pi * zeta, 10 * zeta * zeta);
    EXPECT_NEAR(lf, pi * zeta, 10 * zeta * zeta);
  }
}

TEST(Damping, StrongDampingStaysFinite) {
  for (Real zeta : {1e2, 1e3}) {
    const Real e = restitution_from_damping_ratio(zeta, kForceZero);
    const Real tc = dimensionless_contact_time(zeta, kForceZero);
    EXPECT_TRUE(std::isfinite(tc));
    EXPECT_GE(e, 0.0);
    EXPECT_LT(e, 1e-3);
    // Over-damped asymptote: omega0 t_c = 2 ln(2 zeta) / zeta (1 + O(zeta^-2)).
    EXPECT_NEAR(tc, 2 * std::log(2 * zeta) / zeta, 1e-2 * tc);
  }
}

}  // namespace
}  // namespace dem
