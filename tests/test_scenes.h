#pragma once
// Small configurations built in code, shared by several test files.
#include <cmath>
#include <cstdint>

#include "engine/config.h"

namespace dem::test {

/// Counter-based uniform number in [0, 1) from (seed, index): no shared generator state.
inline double uniform(std::uint64_t seed, std::uint64_t index) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull + index * 0xBF58476D1CE4E5B9ull + 0x94D049BB133111EBull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

/// A jittered lattice of polydisperse spheres with random velocities falling in a closed box,
/// with friction and rolling resistance: contacts are created and removed, and the grid rebuilds.
inline WorldConfig falling_box_scene(int nx, int ny, int nz, std::uint64_t seed) {
  WorldConfig c;
  c.model.gravity = Vec3(0, 0, -9.81);
  ContactConfig contact;
  contact.normal_stiffness = 1e4;
  contact.normal_damping = {DampingKind::restitution, 0.5};
  contact.tangential_damping = {DampingKind::damping_ratio, 0.1};
  contact.sliding_friction = 0.5;
  contact.rolling_friction = 0.05;
  c.contacts = {contact};
  c.integrator.dt = 2e-5;
  c.broadphase.skin = 0.5e-3;
  const double spacing = 0.0104;
  WallConfig box;
  box.kind = WallKind::box;
  box.inside = true;
  box.half_extents = Vec3(0.5 * nx * spacing, 0.5 * ny * spacing, 0.5 * nz * spacing + 0.02);
  box.point = box.half_extents;
  c.walls = {box};
  std::uint64_t draw = 0;
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j)
      for (int k = 0; k < nz; ++k) {
        ParticleConfig p;
        p.radius = 0.004 + 0.001 * uniform(seed, draw++);
        p.position = Vec3((i + 0.5) * spacing, (j + 0.5) * spacing, (k + 0.5) * spacing);
        const double vx = uniform(seed, draw++) - 0.5;
        const double vy = uniform(seed, draw++) - 0.5;
        const double vz = uniform(seed, draw++) - 0.5;
        p.velocity = Vec3(vx, vy, vz);
        c.particles.push_back(p);
      }
  return c;
}

}  // namespace dem::test
