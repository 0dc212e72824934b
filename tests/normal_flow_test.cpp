// Tests of engine/normal_flow.h: the exact flow of one normal contact with onset and release
// (docs/physics.md 2.1, 5.3) under a constant relative forcing a (gravity pressing a ball onto a floor).
// Oracles, written here independently of engine/propagator.h: the closed-form contact flow (damped
// modes about the equilibrium overlap a / omega0^2 = m g / k), free flight as a parabola, onsets as
// roots of quadratics, a release inside a contact by bisection on the closed form, and the analytic
// bounce of an undamped ball on a floor (docs/physics.md 8.6: e = 1, contact time (pi + 2 theta) / omega0).
#include "engine/normal_flow.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "engine/propagator.h"

namespace dem {
namespace {

// The docs/physics.md 8.2 contact, m* = 0.5 kg and k = 1e5 N/m, pressed by gravity onto an immovable floor.
const Real kOmega0 = std::sqrt(1e5 / 0.5);  // [1/s]
constexpr Real kGravity = 9.81;             // [m/s^2]
const Real kRestOverlap = kGravity / (kOmega0 * kOmega0);  // m g / k [m]

constexpr Real kNever = std::numeric_limits<Real>::infinity();

std::string name(Separation separation) { return separation == Separation::overlap ? "overlap" : "force_zero"; }

/// Closed form of delta'' + 2 beta delta' + omega0^2 delta = a from s over t (t < 0 runs backwards):
/// the deviation from the equilibrium a / omega0^2 is a sum of damped modes. Under- or over-damped.
NormalState contact_flow(const NormalOscillator& o, Real a, NormalState s, Real t) {
  const Real w2 = o.omega0 * o.omega0;
  const Real rest = a / w2;
  const Real x0 = s.delta - rest;
  const Real v0 = s.rate;
  if (o.beta < o.omega0) {
    const Real wd = std::sqrt(w2 - o.beta * o.beta);
    const Real e = std::exp(-o.beta * t);
    const Real c = std::cos(wd * t);
    const Real sn = std::sin(wd * t);
    return {rest + e * (x0 * c + (v0 + o.beta * x0) / wd * sn), e * (v0 * c - (w2 * x0 + o.beta * v0) / wd * sn)};
  }
  const Real root = std::sqrt(o.beta * o.beta - w2);
  const Real slow = -w2 / (o.beta + root);
  const Real fast = -(o.beta + root);
  const Real c_slow = (v0 - fast * x0) / (slow - fast);
  const Real c_fast = (slow * x0 - v0) / (slow - fast);
  const Real es = std::exp(slow * t);
  const Real ef = std::exp(fast * t);
  return {rest + c_slow * es + c_fast * ef, slow * c_slow * es + fast * c_fast * ef};
}

NormalState parabola(NormalState s, Real a, Real t) { return {s.delta + s.rate * t + 0.5 * a * t * t, s.rate + a * t}; }

/// The quantity whose sign says the contact pushes: the overlap, or the force per unit mass.
Real pushing_quantity(const NormalOscillator& o, Separation separation, const NormalState& s) {
  return separation == Separation::overlap ? s.delta : o.omega0 * o.omega0 * s.delta + 2 * o.beta * s.rate;
}

/// Positive root of c0 + c1 t + c2 t^2 with c2 > 0 at which it rises, or infinity.
Real rising_root(Real c0, Real c1, Real c2) {
  const Real disc = c1 * c1 - 4 * c2 * c0;
  if (disc < 0) return kNever;
  const Real t = c1 < 0 ? (-c1 + std::sqrt(disc)) / (2 * c2) : -2 * c0 / (c1 + std::sqrt(disc));
  return t >= 0 ? t : kNever;
}

/// Onset time from a free state under a > 0 (docs/physics.md 2.1): the overlap rises through zero or,
/// under force_zero, the force rises through zero while the bodies still overlap.
Real onset_after(const NormalOscillator& o, Separation separation, Real a, const NormalState& s) {
  Real t = rising_root(s.delta, s.rate, 0.5 * a);
  if (separation == Separation::force_zero) {
    const Real w2 = o.omega0 * o.omega0;
    const Real tf = rising_root(w2 * s.delta + 2 * o.beta * s.rate, w2 * s.rate + 2 * o.beta * a, 0.5 * w2 * a);
    if (tf < t && parabola(s, a, tf).delta > 0) t = tf;
  }
  return t;
}

/// Error of `got` against `want` in units of the rest overlap and its velocity scale.
Real error(const NormalState& got, const NormalState& want) {
  return std::max(std::fabs(got.delta - want.delta) / kRestOverlap,
                  std::fabs(got.rate - want.rate) / (kRestOverlap * kOmega0));
}

// ---------------------------------------------------------------------------------------------
// The table fast path (a whole step no longer than a quarter period, coefficients from the table)
// once took the contact-only end state whenever the contact still pushed at the end, and so missed a
// release and re-contact inside the step. Under a > 0 that happens when the pushing quantity dips
// below zero around its minimum: here the minimum is -0.2 of its rest value, at mid-step.

TEST(NormalFlow, TableStepFindsReleaseInsideQuarterPeriod) {
  const Real tau = 1.5 / kOmega0;  // omega0 tau < pi / 2: the table serves this step
  const Real a = kGravity;
  for (const Separation separation : {Separation::overlap, Separation::force_zero}) {
    for (const Real zeta : {0.0, 0.05}) {
      const std::string where = name(separation) + " zeta=" + std::to_string(zeta);
      const NormalOscillator o{kOmega0, zeta * kOmega0};
      const Real w2 = kOmega0 * kOmega0;
      // The state at the minimum of the pushing quantity (zero slope), then back half a step.
      NormalState bottom{-0.2 * kRestOverlap, 0};
      if (separation == Separation::force_zero) {
        const Real force = -0.2 * a;  // per unit mass
        bottom.rate = -2 * o.beta * (a - force) / w2;
        bottom.delta = (force - 2 * o.beta * bottom.rate) / w2;
      }
      const NormalState start = contact_flow(o, a, bottom, -0.5 * tau);
      ASSERT_TRUE(pushes(o, separation, start)) << where;
      ASSERT_GT(pushing_quantity(o, separation, contact_flow(o, a, start, tau)), 0) << where;

      // Release: the pushing quantity falls through zero before the minimum (bisection to round-off).
      Real lo = 0;
      Real hi = 0.5 * tau;
      for (int i = 0; i < 200; ++i) {
        const Real mid = 0.5 * (lo + hi);
        if (pushing_quantity(o, separation, contact_flow(o, a, start, mid)) > 0) {
          lo = mid;
        } else {
          hi = mid;
        }
      }
      const Real t_release = 0.5 * (lo + hi);
      const NormalState released = contact_flow(o, a, start, t_release);
      // Free flight, then a new onset if it comes within the step; within the remaining quarter period
      // the new contact starts rising and cannot release again.
      const Real t_onset = t_release + onset_after(o, separation, a, released);
      NormalState want;
      int want_events = 1;
      if (t_onset < tau) {
        NormalState touched = parabola(released, a, t_onset - t_release);
        want = contact_flow(o, a, touched, tau - t_onset);
        want_events = 2;
      } else {
        want = parabola(released, a, tau - t_release);
      }

      const PropagatorCoefficients table = propagator(o.omega0, o.beta, tau);
      for (const bool use_table : {true, false}) {
        int events = 0;
        const NormalState got = advance_normal(o, separation, a, start, tau, &events, use_table ? &table : nullptr);
        EXPECT_LE(error(got, want), 1e-9) << where << (use_table ? " table" : " no table") << ": got ("
                                           << got.delta << ", " << got.rate << "), want (" << want.delta << ", "
                                           << want.rate << ")";
        EXPECT_EQ(events, want_events) << where;
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// A body touching at rest (delta = 0, delta' = 0) and pressed in (a > 0) was once never taken as an
// onset, so it fell through the floor for a whole step. It must follow the step response of the
// contact from rest, delta(t) = (m g / k) (1 - e^(-beta t) (cos omega_d t + beta/omega_d sin omega_d t)),
// and, damped, settle at the rest overlap m g / k.

TEST(NormalFlow, BodyRestingAtTouchStaysSupported) {
  const Real a = kGravity;
  const Real period = 2 * pi / kOmega0;
  for (const Separation separation : {Separation::overlap, Separation::force_zero}) {
    for (const Real zeta : {0.0, 0.2}) {
      for (const Real omega_h : {0.1, 1.0, 3.7}) {  // the last is longer than a quarter period: no table
        const std::string where = name(separation) + " zeta=" + std::to_string(zeta) + " omega0 h=" + std::to_string(omega_h);
        const NormalOscillator o{kOmega0, zeta * kOmega0};
        const Real h = omega_h / kOmega0;
        const PropagatorCoefficients table = propagator(o.omega0, o.beta, h);
        const int steps = static_cast<int>(std::ceil(40 * period / h));
        NormalState s{0, 0};
        Real worst = 0;
        Real lowest = 0;
        for (int n = 1; n <= steps; ++n) {
          s = advance_normal(o, separation, a, s, h, nullptr, &table);
          worst = std::max(worst, error(s, contact_flow(o, a, {0, 0}, n * h)));
          lowest = std::min(lowest, s.delta);
        }
        EXPECT_LE(worst, 1e-9) << where;
        EXPECT_GE(lowest, -1e-12 * kRestOverlap) << where << ": fell through the floor";
        if (zeta > 0) {
          // 40 periods at zeta = 0.2: e^(-beta t) ~ 1e-22, at rest on the floor.
          EXPECT_NEAR(s.delta, kRestOverlap, 1e-9 * kRestOverlap) << where;
          EXPECT_NEAR(s.rate, 0, 1e-9 * kRestOverlap * kOmega0) << where;
        }
      }
    }
  }
}

// ---------------------------------------------------------------------------------------------
// A cap of 64 events per call once ended a long step early, so a step spanning many bounces finished
// its last part in free flight, through the floor. An undamped ball bounces for ever with e = 1 even
// under gravity: from impact speed v, the contact lasts (pi + 2 theta) / omega0 with
// tan theta = (m g / k) omega0 / v (it starts and ends m g / k short of the equilibrium overlap;
// undamped, docs/physics.md 8.6), and the flight 2 v / g. Start at the apex, run 100 bounce periods in one call.

TEST(NormalFlow, LongStepFollowsEveryBounce) {
  const Real a = kGravity;
  const Real v = 0.05;  // impact speed [m/s]
  const Real theta = std::atan(kRestOverlap * kOmega0 / v);
  const Real bounce = (pi + 2 * theta) / kOmega0 + 2 * v / a;  // [s]
  const NormalState apex{-v * v / (2 * a), 0};
  const int bounces = 100;
  for (const Separation separation : {Separation::overlap, Separation::force_zero}) {
    const NormalOscillator o{kOmega0, 0};
    int events = 0;
    const NormalState got = advance_normal(o, separation, a, apex, bounces * bounce, &events);
    EXPECT_EQ(events, 2 * bounces) << name(separation);
    EXPECT_NEAR(got.delta, apex.delta, 1e-9 * std::fabs(apex.delta)) << name(separation);
    EXPECT_NEAR(got.rate, 0, 1e-9 * v) << name(separation);
  }
}

// ---------------------------------------------------------------------------------------------
// A strongly damped contact released at force zero keeps a residual overlap; pressed again (here by
// a load of a few rest overlaps' worth), the force rises through zero while the bodies still overlap
// and the contact restarts there (docs/physics.md 2.1). Over-damped, the force then rises monotonically
// to its rest value: no second release. The onset must put the state on the pushing side of the
// force-zero condition: a force left an ulp negative was taken by the release search for a
// crossing, and onset and release then alternated an ulp apart (formerly up to the event cap, which
// ended the step in free flight; without a cap such a chatter would not end).

TEST(NormalFlow, ForceOnsetFromResidualOverlapHoldsTheContact) {
  const Real a = kGravity;
  const Real tau = 3 / kOmega0;
  struct Start {
    Real zeta, overlap, rate;  // overlap in rest overlaps, rate in rest overlaps * omega0
  };
  for (const Start& st : {Start{1.5, 0.01, -0.02}, Start{1.5, 0.02, -0.02}, Start{1.5, 0.1, -0.2}, Start{3.0, 0.01, -0.02},
                          Start{2.0, 0.05, -0.1}, Start{2.5, 0.2, -0.5}}) {
    const std::string where = "zeta=" + std::to_string(st.zeta) + " start=(" + std::to_string(st.overlap) + ", " +
                              std::to_string(st.rate) + ")";
    const NormalOscillator o{kOmega0, st.zeta * kOmega0};
    const NormalState start{st.overlap * kRestOverlap, st.rate * kRestOverlap * kOmega0};
    ASSERT_FALSE(pushes(o, Separation::force_zero, start)) << where;
    const Real w2 = kOmega0 * kOmega0;
    const Real t_onset = rising_root(w2 * start.delta + 2 * o.beta * start.rate, w2 * start.rate + 2 * o.beta * a,
                                     0.5 * w2 * a);
    ASSERT_LT(t_onset, tau) << where;
    // The overlap stays positive until then (its minimum, if before the onset, is above zero).
    const Real t_lowest = std::clamp(-start.rate / a, Real{0}, t_onset);
    ASSERT_GT(parabola(start, a, t_lowest).delta, 0) << where;
    const NormalState want = contact_flow(o, a, parabola(start, a, t_onset), tau - t_onset);
    int events = 0;
    const NormalState got = advance_normal(o, Separation::force_zero, a, start, tau, &events);
    EXPECT_LE(error(got, want), 1e-9) << where << ": got (" << got.delta << ", " << got.rate << "), want ("
                                       << want.delta << ", " << want.rate << ")";
    EXPECT_EQ(events, 1) << where;
  }
}

/// The deepest overlap of an impact at speed v without forcing (delta(t) from 0 with delta'(0) = v),
/// in closed form: the time where delta' = 0 and delta there, per damping regime.
Real impact_peak(Real omega0, Real zeta, Real v) {
  if (zeta < 1) {
    const Real root = std::sqrt(1 - zeta * zeta), wd = omega0 * root;
    const Real t = std::atan2(root, zeta) / wd;  // tan(wd t) = wd / beta
    return v / wd * std::exp(-zeta * omega0 * t) * std::sin(wd * t);
  }
  if (zeta == 1) return v / (omega0 * std::exp(1.0));  // t = 1 / omega0: v t e^(-omega0 t)
  const Real root = std::sqrt(zeta * zeta - 1), r1 = omega0 * (-zeta + root), r2 = omega0 * (-zeta - root);
  const Real t = std::log(r2 / r1) / (r1 - r2);
  return v / (r1 - r2) * (std::exp(r1 * t) - std::exp(r2 * t));
}

TEST(NormalFlow, PeakOverlapOfAnImpactMatchesTheClosedForm) {
  // The watch of the deepest overlap (docs/physics.md 9.2) inside a step that holds the whole impact and
  // more (omega0 tau = 10): the first maximum of delta, in every damping regime.
  const Real v = 1;
  for (Real zeta : {0.0, 0.3, 1.0 - 1e-8, 1.0, 1.0 + 1e-8, 3.0, 1e3}) {
    SCOPED_TRACE(::testing::Message() << "zeta " << zeta);
    const NormalOscillator o{kOmega0, zeta * kOmega0};
    const Real expected = impact_peak(kOmega0, zeta, v);
    EXPECT_NEAR(peak_overlap(o, 0, {0, v}, 10 / kOmega0), expected, 1e-9 * expected);
    // Through advance_normal, from just before the onset: found when it is of interest only.
    OverlapWatch watch{0.5 * expected, 0};
    advance_normal(o, Separation::overlap, 0, {-1e-6, v}, 10 / kOmega0, nullptr, nullptr, &watch);
    EXPECT_NEAR(watch.deepest, expected, 1e-9 * expected);
    OverlapWatch uninterested{2 * v / kOmega0, 0};  // beyond the energy bound v / omega0: ends only
    advance_normal(o, Separation::overlap, 0, {-1e-6, v}, 10 / kOmega0, nullptr, nullptr, &uninterested);
    EXPECT_LT(uninterested.deepest, expected);
  }
}

TEST(NormalFlow, PeakOverlapUnderGravityIsTheRestOverlapPlusTheSwing) {
  // Undamped, pressed by gravity from touching at rest: delta swings between 0 and 2 m g / k.
  const NormalOscillator o{kOmega0, 0};
  EXPECT_NEAR(peak_overlap(o, kGravity, {0, 0}, 4 / kOmega0), 2 * kRestOverlap, 1e-9 * kRestOverlap);  // at omega0 t = pi
  // A step ending before the maximum reports the end.
  const Real t = 1 / kOmega0;
  EXPECT_NEAR(peak_overlap(o, kGravity, {0, 0}, t), kRestOverlap * (1 - std::cos(kOmega0 * t)), 1e-9 * kRestOverlap);
}

}  // namespace
}  // namespace dem
