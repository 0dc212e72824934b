#include "engine/tangential_kick.h"

#include <algorithm>

namespace dem {

Real tangential_kick(const LawConstants& c, bool friction, RollingKind rolling, const KickBodies& bodies, const Vec3& n,
                     Real load, Real load_rate, Real tau, Vec3& relative, Vec3& spin_i, Vec3& spin_j,
                     ContactHistory& history) {
  history.tangential_spring = law_detail::project_keep_length(history.tangential_spring, n);
  history.rolling_spring = law_detail::project_keep_length(history.rolling_spring, n);
  TangentialConstants tc{bodies.inv_mass, bodies.inv_inertia_i, bodies.arm_i, friction, rolling, c.k_t, c.c_t, c.mu,
                         c.mu_s, c.k_r, c.c_r, c.mu_r, c.mu_rs, c.r_star, bodies.inv_inertia_j, bodies.arm_j};
  const Vec3 along_n = relative.dot(n) * n;
  TangentialState s{relative - along_n, spin_i, Vec3::Zero(), spin_j};
  const Real dissipated = advance_tangential(tc, n, std::max(load, Real{0}), load_rate, Vec3::Zero(), tau, s, history);
  relative = along_n + s.velocity;
  spin_i = s.spin;
  spin_j = s.spin_j;
  return dissipated;
}

}  // namespace dem
