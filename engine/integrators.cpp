#include "engine/integrators.h"

#include "engine/parallel.h"

namespace dem {

namespace {

// The run's settings are template arguments, so the loop body has no branch on them.
template <bool Rotation, bool Disc>
void kick_as(State& s, Real h, const Vec3& gravity) {
  parallel_for(s.size(), [&](std::size_t p) {
    const Real inv_m = s.inv_mass[p];
    if (inv_m == 0) return;
    s.velocity[p] += h * (inv_m * s.force[p] + gravity);
    if constexpr (Rotation) s.angular_velocity[p] += (h * s.inv_inertia[p]) * s.torque[p];
    if constexpr (Disc) s.velocity[p].z() = 0;
  });
}

}  // namespace

void kick(State& s, Real h, const Vec3& gravity, bool rotation, int dimension) {
  const bool disc = dimension == 2;
  if (rotation)
    disc ? kick_as<true, true>(s, h, gravity) : kick_as<true, false>(s, h, gravity);
  else
    disc ? kick_as<false, true>(s, h, gravity) : kick_as<false, false>(s, h, gravity);
}

void drift(State& s, Real h) {
  parallel_for(s.size(), [&](std::size_t p) { s.position[p] += h * s.velocity[p]; });
}

}  // namespace dem
