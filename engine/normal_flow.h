#pragma once
// The exact flow of one contact's normal coordinate (PHYSICS.md 3.1, 3.3): the overlap delta obeys
// free flight, delta'' = a, while the contact pushes nothing, and the damped oscillator
// delta'' + 2 beta delta' + omega0^2 delta = a while it pushes; the step is split at contact onset
// and at release (force zero, or overlap zero under the overlap convention), each found as a root of
// the closed form, so an isolated contact is exact at any step, even one longer than the contact.
#include "engine/config.h"
#include "engine/propagator.h"

namespace dem {

struct NormalState {
  Real delta;  // overlap [m] (negative: gap)
  Real rate;   // d delta / dt [m/s]
};

/// Spring and dashpot per unit effective mass: omega0^2 = k / m* [1/s^2], 2 beta = c / m* [1/s].
struct NormalOscillator {
  Real omega0;  // [1/s]
  Real beta;    // [1/s]
};

/// True when the contact pushes in state s: delta > 0 and, under force_zero, k delta + c delta' > 0.
bool pushes(const NormalOscillator& o, Separation separation, const NormalState& s);

/// Advances s over tau [s] under constant relative forcing a [m/s^2] (a = -(a_i - a_j) . n).
/// `events` (optional) receives the number of onsets and releases crossed. `whole_step` (optional):
/// precomputed propagator coefficients for exactly tau (PHYSICS.md 3.2), used when the contact
/// pushes at both ends of a step no longer than a quarter period; the release search is then skipped
/// [E]: a release and re-contact inside such a step (a graze of the force through zero) is not
/// resolved.
NormalState advance_normal(const NormalOscillator& o, Separation separation, Real a, NormalState s, Real tau,
                           int* events = nullptr, const PropagatorCoefficients* whole_step = nullptr);

}  // namespace dem
