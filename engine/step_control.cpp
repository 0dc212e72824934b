#include "engine/step_control.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dem {

Real step_error(const TrialState& one, const TrialState& two, const Vec3& displacement, Real h, Real reference_time,
                Real radius, Real velocity_weight, Real dx_min) {
  const Real weight = velocity_weight * reference_time;
  const Real difference = (one.position - two.position).norm() + weight * (one.velocity - two.velocity).norm() +
                          weight * radius * (one.angular_velocity - two.angular_velocity).norm();
  const Real noise = 16 * std::numeric_limits<Real>::epsilon() *
                     (two.position.norm() + weight * two.velocity.norm() + weight * radius * two.angular_velocity.norm());
  const Real numerator = difference > noise ? difference - noise : difference * 0;  // NaN stays NaN
  return numerator / (displacement.norm() + dx_min * radius * h / reference_time);
}

LevelDecision decide_level(Real error, int level, int level_min, int level_max, int order, Real safety,
                           Real tolerance, bool aligned_for_promotion) {
  if (!(error <= tolerance)) {  // NaN rejects too
    if (level <= level_min) return {true, true, level_min};
    // Drop m = max(1, ceil(log2((E / (S tol))^(1/p)))) levels, at least to level_min.
    const Real ratio = error / (safety * tolerance);
    int drop = 1;
    if (std::isfinite(ratio)) drop = std::max(1, static_cast<int>(std::ceil(std::log2(ratio) / order)));
    else drop = level - level_min;
    return {false, false, std::max(level_min, level - drop)};
  }
  // Accepted: promote one level when clearly small (2^p E <= S tol) and the tick is aligned.
  const bool promote = aligned_for_promotion && std::ldexp(error, order) <= safety * tolerance;
  return {true, false, std::min(level_max, promote ? level + 1 : level)};
}

Vec3 richardson(const Vec3& one, const Vec3& two, int order) {
  const Real f = std::ldexp(1.0, order);
  return (f * two - one) / (f - 1);
}

}  // namespace dem
