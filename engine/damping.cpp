// Closed forms of docs/physics.md 2.2. Near zeta = 1 the force-zero branches meet continuously; the
// under- and over-damped formulas are used up to 1 -+ 1e-6 and the critical values in between.
#include "engine/damping.h"

#include <cmath>
#include <limits>

namespace dem {
namespace {

constexpr Real critical_band = 1e-6;

Real force_zero_time(Real zeta) {  // omega0 * t_c with omega0 = 1
  if (zeta < 1 - critical_band) {
    const Real wd = std::sqrt(1 - zeta * zeta);
    return (pi - 2 * std::atan(zeta / wd)) / wd;
  }
  if (zeta <= 1 + critical_band) return 2;
  const Real s = std::sqrt(zeta * zeta - 1);
  // ln((beta + s)/(beta - s)) with beta - s = 1/(beta + s) to avoid cancellation.
  return 2 * std::log(zeta + s) / s;
}

}  // namespace

Real dimensionless_contact_time(Real zeta, Separation separation) {
  if (separation == Separation::force_zero) return force_zero_time(zeta);
  if (zeta >= 1) return std::numeric_limits<Real>::infinity();
  return pi / std::sqrt(1 - zeta * zeta);
}

Real restitution_from_damping_ratio(Real zeta, Separation separation) {
  if (zeta <= 0) return 1;
  if (separation == Separation::overlap) {
    if (zeta >= 1) return 0;
    return std::exp(-zeta * pi / std::sqrt(1 - zeta * zeta));
  }
  return std::exp(-zeta * force_zero_time(zeta));  // e = exp(-beta t_c), beta = zeta omega0
}

Real damping_ratio_from_restitution(Real e, Separation separation) {
  if (e >= 1) return 0;
  if (separation == Separation::overlap) {
    const Real l = std::log(e);
    return -l / std::sqrt(pi * pi + l * l);
  }
  // e decreases monotonically with zeta on (0, inf): bisect on ln e, which is well scaled.
  const Real target = std::log(e);
  Real lo = 0, hi = 1;
  while (std::log(restitution_from_damping_ratio(hi, separation)) > target) hi *= 2;
  for (int it = 0; it < 200 && hi - lo > 1e-15 * hi; ++it) {
    const Real mid = 0.5 * (lo + hi);
    if (std::log(restitution_from_damping_ratio(mid, separation)) > target) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

}  // namespace dem
