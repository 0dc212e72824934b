#pragma once
// The force loops (as Box2D's solver.c: orchestration here, the math in contact_law.h).
// compute_*_contact_forces read positions and velocities, evaluate each contact once (its law constants
// from the material table, MaterialTable::law_constants) and write the
// contact's own slots (force, torques, history); gather_forces then sums, per particle, the
// contributions in ascending partner order (pairs, then walls in key order), so the sums are
// bitwise identical for any thread count and momentum is exchanged exactly.
#include <vector>

#include "engine/contacts.h"
#include "engine/walls.h"

namespace dem {

/// The loops of one run, instantiated for the run's contact law (chosen once, never per contact).
struct ForceKernels {
  void (*pair_forces)(const State&, const MaterialTable&, PairContacts&, Real h) = nullptr;
  void (*wall_forces)(const State&, const MaterialTable&, const Walls&, WallContacts&, Real h) = nullptr;
  bool uses_rotation = false;
};

ForceKernels select_force_kernels(Separation separation, bool friction, RollingKind rolling);

/// Sums contact forces and torques per particle into state.force and state.torque.
void gather_forces(State& state, const PairContacts& pairs, const WallContacts& walls,
                   const ContactAdjacency& adjacency, bool rotation, int dimension);

/// Power of the moving walls on the particles through these contacts [W] (serial, in contact order).
Real wall_power(const Walls& walls, const WallContacts& contacts);
/// Resultant force and torque of the particles on each wall (serial, in contact order).
void accumulate_wall_loads(const Walls& walls, const WallContacts& contacts, std::vector<WallLoad>& loads);

}  // namespace dem
