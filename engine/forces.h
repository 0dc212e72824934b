#pragma once
// The force loops (as Box2D's solver.c: orchestration here, the math in contact_law.h).
// compute_*_contact_forces read positions and velocities, evaluate each contact once (its law constants
// from the material table, MaterialTable::law_constants) and write the
// contact's own slots (force, torques, history); gather_forces then sums, per particle, the
// contributions in ascending partner order (pairs, then walls in key order), so the sums are
// bitwise identical for any thread count and momentum is exchanged exactly.
#include <vector>

#include "engine/contacts.h"
#include "engine/neighbour_contacts.h"
#include "engine/walls.h"

namespace dem {

/// The velocity a dashpot sees (IntegratorConfig::predicted_dashpot). Velocity Verlet evaluates forces
/// between its two kicks, at the half-step velocity v(t + h/2): a dashpot then lags by h/2, so a
/// lasting damped contact is only first order. `predicted` adds the second half kick the previous
/// forces would give (v + h/2 (F/m + g), omega + h/2 T/I): second order, for a stability limit of
/// omega0 h < 2 (sqrt(1 + 4 zeta^2) - 2 zeta) instead of 2 (sqrt(1 + zeta^2) - zeta) (docs/physics.md 4.2
/// gives the second; the first is the predicted scheme's amplification matrix, tests/dashpot_test.cpp).
struct DashpotVelocity {
  bool predicted = false;
  Vec3 gravity = Vec3::Zero();  // [m/s^2]
  int dimension = 3;
};

/// The loops of one run, instantiated for the run's contact law (chosen once, never per contact).
/// h is the step the springs advance by [s]; state.force and state.torque still hold the previous
/// evaluation's sums (the gather writes them afterwards), which a predicted dashpot reads.
struct ForceKernels {
  void (*pair_forces)(const State&, const MaterialTable&, PairContacts&, Real h, const DashpotVelocity&) = nullptr;
  /// The same over a persistent list (neighbour_contacts.h): contacts start and end in their slots.
  void (*neighbour_forces)(const State&, const MaterialTable&, NeighbourContacts&, Real h,
                           const DashpotVelocity&) = nullptr;
  /// `touches`: each contact's geometry at these positions, as update_wall_contacts leaves it.
  void (*wall_forces)(const State&, const MaterialTable&, const Walls&, WallContacts&,
                      const std::vector<WallTouch>& touches, Real h, const DashpotVelocity&) = nullptr;
  bool uses_rotation = false;
};

ForceKernels select_force_kernels(Separation separation, bool friction, RollingKind rolling);

/// Sums contact forces and torques per particle into state.force and state.torque.
void gather_forces(State& state, const PairContacts& pairs, const WallContacts& walls,
                   const ContactAdjacency& adjacency, bool rotation, int dimension);

/// The same from a persistent list, in the same order and to the same bits: each particle's slots
/// as j (NeighbourContacts::reverse_slot), then its own row's, then its wall contacts
/// wall_start[p] .. wall_start[p + 1]. Torques come from the stored n x force. Idle slots hold zero
/// force, moment and rolling torque and add nothing: a sum that starts at +0 never becomes -0, so
/// adding zeros leaves its bits alone.
void gather_neighbour_forces(State& state, const NeighbourContacts& neighbours, const WallContacts& walls,
                             const std::vector<std::uint32_t>& wall_start, bool rotation, int dimension);

/// Power of the moving walls on the particles through these contacts [W] (serial, in contact order).
Real wall_power(const Walls& walls, const WallContacts& contacts);
/// Adds to `power` that of the moving walls through contact k [W], as wall_power sums it.
void add_wall_contact_power(const Walls& walls, const WallContacts& contacts, std::size_t k, Real& power);
/// Resultant force and torque of the particles on each wall (serial, in contact order).
void accumulate_wall_loads(const Walls& walls, const WallContacts& contacts, std::vector<WallLoad>& loads);

}  // namespace dem
