#pragma once
// The exact flow of one contact's normal coordinate (docs/physics.md 5.1, 5.3): the overlap delta obeys
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

/// The deepest overlap a flow reaches inside its step, for the divergence watch (docs/physics.md 9.2: flag
/// an overlap the linear law does not describe, even when a whole impact fits in one step). Cheap
/// below `depth_of_interest`: a contact whose oscillator energy cannot carry it deeper reports the
/// overlap at its ends; above, the true peak inside the step.
struct OverlapWatch {
  Real depth_of_interest = 0;  // [m]
  Real deepest = 0;            // out: the largest overlap seen, max over calls [m]
};

/// Advances s over tau [s] under constant relative forcing a [m/s^2] (a = -(a_i - a_j) . n), through
/// any number of onsets and releases (a long step may hold many bounces). A body touching at rest
/// (delta = 0, delta' = 0) and pressed in (a > 0) starts a contact at once.
/// `events` (optional) is increased by the number of onsets and releases crossed. `whole_step`
/// (optional): precomputed propagator coefficients for exactly tau (docs/physics.md 5.2). In a step no
/// longer than a quarter period the pushing quantity (overlap, or force under force_zero) has at most
/// one extremum, so when the contact pushes at both ends and that quantity did not fall at the start
/// and rise at the end, no release can lie inside: the coefficients give the end state and the
/// release search is skipped.
NormalState advance_normal(const NormalOscillator& o, Separation separation, Real a, NormalState s, Real tau,
                           int* events = nullptr, const PropagatorCoefficients* whole_step = nullptr,
                           OverlapWatch* watch = nullptr);

/// Records in `watch` the deepest overlap of a pushing stretch of the contact flow from s over tau,
/// ending in `end`: the ends' overlap, or the true peak when the oscillator's energy could carry the
/// contact beyond depth_of_interest.
void watch_overlap(OverlapWatch& watch, const NormalOscillator& o, Real a, const NormalState& s, Real tau,
                   const NormalState& end);

/// Largest overlap on the contact flow from s over [0, tau] (the contact pushing throughout): the
/// first maximum of delta(t), where delta' falls through 0, or an end. The shifted oscillator's
/// energy (delta - a / omega0^2)^2 + (delta' / omega0)^2 never grows, so no later maximum is deeper.
Real peak_overlap(const NormalOscillator& o, Real a, NormalState s, Real tau);

}  // namespace dem
