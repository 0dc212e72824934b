#pragma once
// What the VTK writers write, taken from a World after a step: the particles with their forces,
// materials and coordination numbers, and the contact network. Reads the World only.
#include "engine/vtk_writer.h"

namespace dem {

class World;

/// Every particle in slot (id) order: state, radius, level, the contact force and torque sums of the last
/// evaluation, material index and name table, and the coordination number (the pair contacts and wall
/// contacts the World lists for it, the same lists the series' `contacts` and `wall_contacts` count).
ParticleSnapshot particle_snapshot(const World& world);

/// One line per listed pair contact (in key order) and per wall contact (after them, in key order),
/// with the contact force split into its part along the normal and the rest.
ContactSnapshot contact_snapshot(const World& world);

}  // namespace dem
