#pragma once
// Velocity Verlet (kick-drift-kick) on the particle arrays. Reads force, torque, masses; writes
// velocity, angular velocity, position. Threading: per particle, each body writes its own slot.
// Immovable particles (inverse mass 0) keep their velocity and feel no gravity.
#include "engine/state.h"

namespace dem {

/// v += h (F/m + g), and omega += h T/I when the run has rotation.
void kick(State& state, Real h, const Vec3& gravity, bool rotation, int dimension);

/// x += h v.
void drift(State& state, Real h);

}  // namespace dem
