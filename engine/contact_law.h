#pragma once
// The linear spring-dashpot contact law with tangential spring-slider and rolling resistance
// (PHYSICS.md 1.1, 1.3, 1.4, 1.5). Pure functions: kinematics, constants and history in; force,
// rolling torque and new history out. No loops, allocation, I/O or throwing here. The law is chosen
// once per run through its template parameters, so the force loop has no per-contact switches.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "engine/config.h"
#include "engine/materials.h"

namespace dem {

/// Which rolling-resistance variant a run uses; `none` skips all rolling work.
enum class RollingKind { none, standard, seed };

/// Mode bits of a contact (PHYSICS.md 1.5): sliding (else stick) and rolling (else static hold).
enum ContactMode : std::uint8_t { mode_sliding = 1, mode_rolling = 2 };

/// History carried by a contact from step to step.
struct ContactHistory {
  Vec3 tangential_spring = Vec3::Zero();  // xi [m], in the tangent plane
  Vec3 rolling_spring = Vec3::Zero();     // theta [rad], perpendicular to the normal
  std::uint8_t mode = 0;                  // ContactMode bits
};

/// Relative motion at one contact, i against j (j may be a wall).
struct ContactKinematics {
  Vec3 normal;               // unit, from j towards i
  Real overlap;              // delta > 0 [m]
  Real overlap_rate;         // d delta / dt = -(u . n) [m/s]
  Vec3 tangential_velocity;  // u_t: slip velocity of i against j at the contact point [m/s]
  Vec3 rolling_velocity;     // omega_r = omega_i - omega_j without the spin about n [rad/s]
};

/// What the law returns: the force on i (j gets its negative) and the rolling torque on i.
struct ContactResponse {
  Vec3 force;           // [N]
  Vec3 rolling_torque;  // [N m]
  Real normal_force;    // F_n [N], the scalar the friction limits use
  Real power;           // rate of work done by the particles on the contact [W]
  Real elastic;         // energy stored in the contact's springs after the update [J]
};

namespace law_detail {

/// Rotates a history vector into the plane perpendicular to n, keeping its length.
inline Vec3 project_keep_length(const Vec3& v, const Vec3& n) {
  const Real length2 = v.squaredNorm();
  if (length2 == 0) return v;
  Vec3 p = v - v.dot(n) * n;
  const Real p2 = p.squaredNorm();
  if (p2 == 0) return Vec3::Zero();
  p *= std::sqrt(length2 / p2);
  return p;
}

/// Spring-dashpot-slider on one channel: history s advanced by rate * h, trial value
/// -k s - c rate, held while within `hold_limit` (mode bit clear), otherwise limited to
/// `slide_limit` along the trial direction with the spring reset to match (PHYSICS.md 1.3).
/// Slide -> stick needs the trial within min(kinetic, static) limits, so a contact cannot
/// alternate every step when mu_s < mu.
inline Vec3 spring_slider(Vec3& spring, std::uint8_t& mode, std::uint8_t bit, const Vec3& rate, Real k, Real c,
                          Real static_limit, Real kinetic_limit, Real h) {
  spring += rate * h;
  const Vec3 trial = -k * spring - c * rate;
  const bool was_sliding = (mode & bit) != 0;
  const Real hold_limit = was_sliding ? std::min(static_limit, kinetic_limit) : static_limit;
  const Real trial_norm = trial.norm();
  if (trial_norm <= hold_limit) {
    mode = static_cast<std::uint8_t>(mode & ~bit);
    return trial;
  }
  mode = static_cast<std::uint8_t>(mode | bit);
  const Vec3 limited = trial * (kinetic_limit / trial_norm);
  spring = -(limited + c * rate) / k;
  return limited;
}

/// Rolling resistance as Ai et al. (2011) model C: an elastic-plastic rotational spring whose elastic
/// torque -k theta is capped (static limit to leave the static state, the smaller of the two limits
/// to return to it, the kinetic limit while rolling), plus a viscous torque only while static, the
/// sum bounded by the static limit.
/// Capping the spring alone, not spring plus dashpot, keeps the dashpot from breaking a hold that the
/// spring could carry (PHYSICS.md 1.4).
inline Vec3 rolling_spring(Vec3& spring, std::uint8_t& mode, const Vec3& rate, Real k, Real c, Real static_limit,
                           Real kinetic_limit, Real h) {
  spring += rate * h;
  Vec3 elastic = -k * spring;
  const bool was_rolling = (mode & mode_rolling) != 0;
  const Real hold_limit = was_rolling ? std::min(static_limit, kinetic_limit) : static_limit;
  const Real elastic_norm = elastic.norm();
  if (elastic_norm <= hold_limit) {
    mode = static_cast<std::uint8_t>(mode & ~mode_rolling);
    // The dashpot acts while static, but the total never exceeds what static friction can supply.
    Vec3 total = elastic - c * rate;
    const Real total_norm = total.norm();
    if (total_norm > static_limit) total *= static_limit / total_norm;
    return total;
  }
  mode = static_cast<std::uint8_t>(mode | mode_rolling);
  elastic *= kinetic_limit / elastic_norm;
  spring = -elastic / k;
  return elastic;
}

}  // namespace law_detail

template <Separation Sep, bool Friction, RollingKind Rolling>
struct LinearSpringDashpot {
  static constexpr bool uses_rotation = Friction || Rolling != RollingKind::none;

  static ContactResponse evaluate(const LawConstants& c, const ContactKinematics& k, ContactHistory& history,
                                  Real h) {
    ContactResponse out;
    Real fn = c.k_n * k.overlap + c.c_n * k.overlap_rate;
    if constexpr (Sep == Separation::force_zero) fn = std::max(fn, Real{0});
    out.normal_force = fn;
    out.force = fn * k.normal;
    out.rolling_torque = Vec3::Zero();
    const Real load = std::max(fn, Real{0});  // friction limits never use an attractive force

    if constexpr (Friction) {
      history.tangential_spring = law_detail::project_keep_length(history.tangential_spring, k.normal);
      out.force += law_detail::spring_slider(history.tangential_spring, history.mode, mode_sliding,
                                             k.tangential_velocity, c.k_t, c.c_t, c.mu_s * load, c.mu * load, h);
    }
    if constexpr (Rolling != RollingKind::none) {
      bool active = true;
      if constexpr (Rolling == RollingKind::seed && Friction) active = (history.mode & mode_sliding) == 0;
      if (active) {
        history.rolling_spring = law_detail::project_keep_length(history.rolling_spring, k.normal);
        out.rolling_torque = law_detail::rolling_spring(history.rolling_spring, history.mode, k.rolling_velocity,
                                                        c.k_r, c.c_r, c.mu_rs * c.r_star * load,
                                                        c.mu_r * c.r_star * load, h);
      } else {
        history.rolling_spring.setZero();
        history.mode = static_cast<std::uint8_t>(history.mode | mode_rolling);
      }
    }
    // Energy bookkeeping: the power the particles put into the contact and what its springs hold;
    // their difference, integrated, is what the contact dissipated. Under force_zero a released
    // normal spring (F_n clamped to 0) holds nothing: that energy is lost at the force-zero instant.
    const Vec3 tangential_force = out.force - fn * k.normal;
    out.power = fn * k.overlap_rate - tangential_force.dot(k.tangential_velocity) -
                out.rolling_torque.dot(k.rolling_velocity);
    out.elastic = fn > 0 || Sep == Separation::overlap ? 0.5 * c.k_n * k.overlap * k.overlap : 0.0;
    if constexpr (Friction) out.elastic += 0.5 * c.k_t * history.tangential_spring.squaredNorm();
    if constexpr (Rolling != RollingKind::none) out.elastic += 0.5 * c.k_r * history.rolling_spring.squaredNorm();
    return out;
  }
};

}  // namespace dem
