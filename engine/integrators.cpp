#include "engine/integrators.h"

#include "engine/parallel.h"

namespace dem {

void kick(State& s, Real h, const Vec3& gravity, bool rotation, int dimension) {
  parallel_for(s.size(), [&](std::size_t p) {
    const Real inv_m = s.inv_mass[p];
    if (inv_m == 0) return;
    s.velocity[p] += h * (inv_m * s.force[p] + gravity);
    if (rotation) s.angular_velocity[p] += (h * s.inv_inertia[p]) * s.torque[p];
    if (dimension == 2) s.velocity[p].z() = 0;
  });
}

void drift(State& s, Real h) {
  parallel_for(s.size(), [&](std::size_t p) { s.position[p] += h * s.velocity[p]; });
}

}  // namespace dem
