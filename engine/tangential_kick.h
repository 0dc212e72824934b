#pragma once
// The tangential half of the exact stepper's split pair and cylinder flows (exact_stepper.h): the
// tangential and rolling channel of one contact advanced over tau with its geometry (normal, lever
// arms) and normal force frozen, exactly in its modes and split at its mode switches (exact_friction.h).
// Positions do not move here: the normal flow carries all displacement. The caller alternates this
// with the exact normal flow in a symmetric (Strang) splitting and hands it the normal force over each
// half piece as a line (exact_stepper.cpp, split_stretch).
// Pure function: safe from any thread.
#include "engine/contact_law.h"
#include "engine/exact_friction.h"
#include "engine/types.h"

namespace dem {

/// The two bodies of a contact as the tangential channel sees them.
struct KickBodies {
  Real inv_mass;       // 1/m* of a pair, 1/m of a particle on a wall [1/kg]
  Real inv_inertia_i;  // [1/(kg m^2)]
  Real inv_inertia_j;  // 0 for a wall [1/(kg m^2)]
  Real arm_i;          // R_i - delta/2 [m]
  Real arm_j;          // R_j - delta/2 [m]; unused for a wall
};

/// Advances the channel over tau [s] under the normal force load + load_rate t [N], [N/s] (clamped at 0,
/// as the law's limits are). n: unit normal from j into i. `relative`: velocity of i's centre against
/// j's (a pair) or against the wall's material velocity at i's centre [m/s]; only its part across n
/// changes. `spin_i`, `spin_j`: angular velocities [rad/s] (on a wall: i's relative to the wall's, and
/// spin_j zero). The history's springs are first turned into the current tangent plane keeping their
/// lengths (as contact_law.h does each step). Returns the energy the channel dissipated [J], in the frame
/// where j's centre (or the wall material at i's centre) is at rest: the lab value, the wall's work being
/// booked apart.
Real tangential_kick(const LawConstants& c, bool friction, RollingKind rolling, const KickBodies& bodies, const Vec3& n,
                     Real load, Real load_rate, Real tau, Vec3& relative, Vec3& spin_i, Vec3& spin_j,
                     ContactHistory& history);

}  // namespace dem
