#include "engine/normal_flow.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/propagator.h"

namespace dem {
namespace {

constexpr Real never = std::numeric_limits<Real>::infinity();

/// Smallest root t in [0, limit] of c0 + c1 t + c2 t^2 at which the quadratic rises (its derivative
/// c1 + 2 c2 t > 0, or a double root of a convex quadratic), or infinity. Roots by the
/// cancellation-free formula. A root at t = 0 counts: a contact touching exactly at the start of a
/// step begins at once (a falling root there, as right after a release, does not).
Real first_rising_root(Real c0, Real c1, Real c2, Real limit) {
  if (c0 == 0) {
    // Touching now (right after a release, or at rest): the roots are 0 and -c1/c2, exactly, with no
    // discriminant to underflow for a tiny c1. A double root at 0 of a convex quadratic (a body
    // touching at rest, pressed in) rises at once, though its derivative is zero there.
    if (c1 > 0 || (c1 == 0 && c2 > 0)) return 0;
    const Real t = c1 < 0 && c2 > 0 ? -c1 / c2 : never;
    return t <= limit ? t : never;
  }
  Real roots[2];
  int count = 0;
  if (c2 == 0) {
    if (c1 != 0) roots[count++] = -c0 / c1;
  } else {
    const Real disc = c1 * c1 - 4 * c2 * c0;
    if (disc < 0) return never;
    const Real q = -0.5 * (c1 + std::copysign(std::sqrt(disc), c1));
    if (q != 0) roots[count++] = c0 / q;
    roots[count++] = q / c2;
  }
  Real best = never;
  for (int k = 0; k < count; ++k) {
    const Real t = roots[k];
    if (t >= 0 && t <= limit && c1 + 2 * c2 * t > 0 && t < best) best = t;
  }
  return best;
}

NormalState free_flight(NormalState s, Real a, Real t) {
  return {s.delta + s.rate * t + 0.5 * a * t * t, s.rate + a * t};
}

NormalState apply(const PropagatorCoefficients& p, NormalState s, Real a) {
  return {p.phi11 * s.delta + p.phi12 * s.rate + p.gamma1 * a, p.phi21 * s.delta + p.phi22 * s.rate + p.gamma2 * a};
}

NormalState oscillate(const NormalOscillator& o, NormalState s, Real a, Real t) {
  return apply(propagator(o.omega0, o.beta, t), s, a);
}

struct Onset {
  Real time;      // [s], infinity if none
  bool by_force;  // the force rose through zero at a residual overlap (else delta rose through 0)
};

/// The next onset from free flight within `limit`: delta rises through 0 or, under force_zero with
/// delta > 0, the spring-dashpot force rises through 0 (a released contact that is pressed again,
/// e.g. by gravity).
Onset onset_time(const NormalOscillator& o, Separation separation, NormalState s, Real a, Real limit) {
  Onset onset{first_rising_root(s.delta, s.rate, 0.5 * a, limit), false};
  if (separation == Separation::force_zero) {
    const Real w2 = o.omega0 * o.omega0, b2 = 2 * o.beta;
    const Real tf = first_rising_root(w2 * s.delta + b2 * s.rate, w2 * s.rate + b2 * a, 0.5 * w2 * a, limit);
    if (tf < onset.time && free_flight(s, a, tf).delta > 0) onset = {tf, true};
  }
  return onset;
}

/// Rate of change, along the contact flow, of the quantity whose sign decides pushes(): the overlap,
/// or under force_zero the force per unit mass omega0^2 delta + 2 beta delta', whose derivative takes
/// delta'' = a - omega0^2 delta - 2 beta delta' from the contact equation.
Real push_slope(const NormalOscillator& o, Separation separation, Real a, const NormalState& s) {
  if (separation == Separation::overlap) return s.rate;
  const Real w2 = o.omega0 * o.omega0;
  return w2 * s.rate + 2 * o.beta * (a - w2 * s.delta - 2 * o.beta * s.rate);
}

/// Puts s exactly on the force-zero condition omega0^2 delta + 2 beta delta' = 0 by moving the overlap
/// to the residual -2 beta delta' / omega0^2 (docs/physics.md 2.1), rounded one ulp towards `side` so that
/// pushes() evaluates the force as >= 0 (+infinity) or <= 0 (-infinity). The overlap, not the rate, is
/// moved: solving for the rate would divide round-off by a small beta.
void place_on_force_zero(const NormalOscillator& o, NormalState& s, Real side) {
  const Real w2 = o.omega0 * o.omega0;
  if (w2 > 0) s.delta = std::nextafter(-(2 * o.beta * s.rate) / w2, side);
  else s.rate = 0;  // no spring: the force is 2 beta delta' alone
}

/// Puts a state that has just begun to push exactly on its onset condition, on the pushing side, so the
/// release search cannot take round-off for the crossing just made and end the contact at once.
void place_at_onset(const NormalOscillator& o, bool by_force, NormalState& s) {
  if (by_force && o.beta > 0) {
    place_on_force_zero(o, s, never);
  } else {
    s.delta = 0;
    s.rate = std::max(s.rate, Real{0});  // an onset never recedes (touch at rest: rate 0)
  }
}

/// The same at a release, on the non-pushing side, so that the onset search starts from a state that
/// does not push. (A state left pushing by round-off would need a zero-time switch back to contact,
/// and such switches can chatter without end between two roots an ulp apart.)
void place_at_release(const NormalOscillator& o, Separation separation, NormalState& s) {
  if (separation == Separation::force_zero && o.beta > 0) {
    place_on_force_zero(o, s, -never);
  } else {
    s.delta = 0;
    s.rate = std::min(s.rate, Real{0});  // a release never approaches
  }
}

}  // namespace

void watch_overlap(OverlapWatch& watch, const NormalOscillator& o, Real a, const NormalState& s, Real tau,
                   const NormalState& end) {
  Real deepest = std::max(s.delta, end.delta);
  if (o.omega0 > 0) {
    // The shifted oscillator's energy bounds the overlap the stretch can reach; only when that bound
    // is of interest is the peak looked for.
    const Real rest = a / (o.omega0 * o.omega0);
    const Real reach = rest + std::hypot(s.delta - rest, s.rate / o.omega0);
    if (reach > watch.depth_of_interest && reach > deepest) deepest = std::max(deepest, peak_overlap(o, a, s, tau));
  }
  watch.deepest = std::max(watch.deepest, deepest);
}

Real peak_overlap(const NormalOscillator& o, Real a, NormalState s, Real tau) {
  Real deepest = std::max(s.delta, oscillate(o, s, a, tau).delta);
  // delta' solves the homogeneous equation: its zeros are at least pi / omega0 apart, so samples a
  // quarter period apart never hold two zeros in one interval. The first fall through 0 is the
  // deepest maximum; 64 intervals cover 16 periods, past the first maximum of any impact.
  constexpr int samples = 64;
  const Real spacing = o.omega0 > 0 ? std::min(tau / samples, 0.5 * pi / o.omega0) : tau / samples;
  if (!(spacing > 0)) return deepest;
  Real t0 = 0, rate0 = s.rate;
  for (int k = 1; k <= samples && t0 < tau; ++k) {
    const Real t1 = std::min(tau, k * spacing);
    const Real rate1 = oscillate(o, s, a, t1).rate;
    if (rate0 > 0 && rate1 <= 0) {
      Real lo = t0, hi = t1;
      for (int i = 0; i < 60; ++i) {
        const Real mid = 0.5 * (lo + hi);
        (oscillate(o, s, a, mid).rate > 0 ? lo : hi) = mid;
      }
      return std::max(deepest, oscillate(o, s, a, 0.5 * (lo + hi)).delta);
    }
    t0 = t1;
    rate0 = rate1;
  }
  return deepest;
}

bool pushes(const NormalOscillator& o, Separation separation, const NormalState& s) {
  if (s.delta <= 0) return false;
  return separation == Separation::overlap || o.omega0 * o.omega0 * s.delta + 2 * o.beta * s.rate > 0;
}

NormalState advance_normal(const NormalOscillator& o, Separation separation, Real a, NormalState s, Real tau,
                           int* events, const PropagatorCoefficients* whole_step, OverlapWatch* watch) {
  bool in_contact = pushes(o, separation, s);
  if (whole_step && in_contact && tau * o.omega0 <= 0.5 * pi) {
    // The slope of the pushing quantity solves the homogeneous equation, so its zeros are pi/omega_d
    // apart (one at most when over-damped): within a quarter period the quantity has one extremum at
    // most. Pushing at both ends, it stopped pushing in between only if it passed a minimum, i.e. fell
    // at the start and rose at the end; otherwise no release can hide inside.
    const NormalState end = apply(*whole_step, s, a);
    const bool dipped = push_slope(o, separation, a, s) < 0 && push_slope(o, separation, a, end) > 0;
    if (pushes(o, separation, end) && !dipped) {
      if (watch) watch_overlap(*watch, o, a, s, tau, end);
      return end;
    }
  }
  Real left = tau;
  // Each pass ends at an event or at the end of the step, so one step holds any number of bounces.
  // Events put the state exactly on their side of the switching condition, so the next search cannot
  // find the crossing just made. Should round-off still make the flow chatter (events that advance
  // time by a few ulps only, e.g. at a tangency), the loop stops after a run of them and the rest of
  // the step keeps the current mode.
  constexpr int max_stalled_events = 16;
  constexpr Real no_progress = 16 * std::numeric_limits<Real>::epsilon();  // fraction of the time left
  int stalled = 0;
  while (left > 0 && stalled < max_stalled_events) {
    const Real left_before = left;
    if (in_contact) {
      const Real release = separation == Separation::force_zero
                               ? force_zero_time(o.omega0, o.beta, s.delta, s.rate, a)
                               : overlap_zero_time(o.omega0, o.beta, s.delta, s.rate, a);
      if (!(release < left)) {
        const NormalState end = oscillate(o, s, a, left);
        if (watch) watch_overlap(*watch, o, a, s, left, end);
        return end;
      }
      const NormalState end = oscillate(o, s, a, release);
      if (watch) watch_overlap(*watch, o, a, s, release, end);
      s = end;
      left -= release;
      place_at_release(o, separation, s);
    } else {
      const Onset onset = onset_time(o, separation, s, a, left);
      if (!(onset.time < left)) return free_flight(s, a, left);
      s = free_flight(s, a, onset.time);
      left -= onset.time;
      place_at_onset(o, onset.by_force, s);
    }
    in_contact = !in_contact;
    if (events) ++*events;
    stalled = left < left_before * (1 - no_progress) ? 0 : stalled + 1;
  }
  if (!in_contact) return free_flight(s, a, left);
  const NormalState end = oscillate(o, s, a, left);
  if (watch) watch_overlap(*watch, o, a, s, left, end);
  return end;
}

}  // namespace dem
