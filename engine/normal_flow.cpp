#include "engine/normal_flow.h"

#include <cmath>
#include <limits>

#include "engine/propagator.h"

namespace dem {
namespace {

constexpr Real never = std::numeric_limits<Real>::infinity();

/// Smallest root t in [0, limit] of c0 + c1 t + c2 t^2 at which the quadratic rises (its derivative
/// c1 + 2 c2 t > 0), or infinity. Roots by the cancellation-free formula. A root at t = 0 counts: a
/// contact touching exactly at the start of a step begins at once (a falling root there, as right
/// after a release, does not).
Real first_rising_root(Real c0, Real c1, Real c2, Real limit) {
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

}  // namespace

bool pushes(const NormalOscillator& o, Separation separation, const NormalState& s) {
  if (s.delta <= 0) return false;
  return separation == Separation::overlap || o.omega0 * o.omega0 * s.delta + 2 * o.beta * s.rate > 0;
}

NormalState advance_normal(const NormalOscillator& o, Separation separation, Real a, NormalState s, Real tau,
                           int* events, const PropagatorCoefficients* whole_step) {
  bool in_contact = pushes(o, separation, s);
  if (whole_step && in_contact && tau * o.omega0 <= 0.5 * pi) {
    const NormalState end = apply(*whole_step, s, a);
    if (pushes(o, separation, end)) return end;
  }
  Real left = tau;
  // Each pass ends at an event or at the end of the step; a contact can only bounce so often within
  // one step, but a cap guards against chattering at round-off.
  for (int pass = 0; pass < 64 && left > 0; ++pass) {
    if (in_contact) {
      const Real release = separation == Separation::force_zero
                               ? force_zero_time(o.omega0, o.beta, s.delta, s.rate, a)
                               : overlap_zero_time(o.omega0, o.beta, s.delta, s.rate, a);
      if (!(release < left)) return oscillate(o, s, a, left);
      s = oscillate(o, s, a, release);
      left -= release;
    } else {
      const Onset onset = onset_time(o, separation, s, a, left);
      if (!(onset.time < left)) return free_flight(s, a, left);
      s = free_flight(s, a, onset.time);
      left -= onset.time;
      // Put the state exactly on the onset condition: round-off on the wrong side would make the
      // release search see the zero crossing just passed and end the contact at once.
      if (onset.by_force && o.beta > 0) s.rate = -o.omega0 * o.omega0 * s.delta / (2 * o.beta);
      else s.delta = 0;
    }
    in_contact = !in_contact;
    if (events) ++*events;
  }
  return in_contact ? oscillate(o, s, a, left) : free_flight(s, a, left);
}

}  // namespace dem
