#pragma once
// Velocity Verlet (kick-drift-kick) on the particle arrays. Reads force, torque, masses; writes
// velocity, angular velocity, position. Threading: per particle, each body writes its own slot.
// Immovable particles (inverse mass 0) keep their velocity and feel no gravity.
#include "engine/state.h"
#include "engine/step_watch.h"

namespace dem {

/// v += h (F/m + g), and omega += h T/I when the run has rotation.
void kick(State& state, Real h, const Vec3& gravity, bool rotation, int dimension);

/// x += h v.
void drift(State& state, Real h);

/// kick(h_kick), then drift(h_drift): the same arithmetic, particle by particle in one pass over the
/// arrays instead of two.
void kick_drift(State& state, Real h_kick, Real h_drift, const Vec3& gravity, bool rotation, int dimension);

/// What a step's closing kick leaves: whether every position, velocity and spin is finite, and the
/// largest step_travel (step_watch.h) for a next step of h.
struct KickCheck {
  bool finite = true;
  Worst travel;
};

/// kick(h_kick), then the check for a next step of h_travel, in one pass over the arrays.
KickCheck kick_and_check(State& state, Real h_kick, Real h_travel, const Vec3& gravity, bool rotation, int dimension);

}  // namespace dem
