#pragma once
// The linear spring-dashpot contact law with tangential spring-slider and rolling resistance
// (docs/physics.md 2.1, 2.3, 2.4, 2.5). Pure functions: kinematics, constants and history in; force,
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

/// Mode bits of a contact (docs/physics.md 2.5): sliding (else stick) and rolling (else static hold).
enum ContactMode : std::uint8_t { mode_sliding = 1, mode_rolling = 2 };

/// History carried by a contact from step to step.
struct ContactHistory {
  Vec3 tangential_spring = Vec3::Zero();  // xi [m], in the tangent plane
  Vec3 rolling_spring = Vec3::Zero();     // theta [rad], perpendicular to the normal
  std::uint8_t mode = 0;                  // ContactMode bits
  // Energy books of this contact, for collision energy spectra (docs/physics.md 7.4):
  Real normal_work = 0;      // work of the particles on the normal spring-dashpot since it formed [J]
  Real normal_elastic = 0;   // energy in the normal spring at the last evaluation [J]
  Real impact_energy = -1;   // m* v_n^2 / 2 at its first evaluation [J]; negative until then
};

/// Relative motion at one contact, i against j (j may be a wall).
struct ContactKinematics {
  Vec3 normal;               // unit, from j towards i
  Real overlap;              // delta > 0 [m]
  Vec3 previous_force;       // the contact's force at the previous evaluation (0 for a new one), for the energy books [N]
  Real overlap_rate;         // d delta / dt = -(u . n) [m/s]
  Vec3 tangential_velocity;  // u_t: slip velocity of i against j at the contact point [m/s]
  Vec3 rolling_velocity;     // omega_r = omega_i - omega_j without the spin about n [rad/s]
  // The same three rates as the dashpots see them (DashpotVelocity, forces.h): equal to the ones above
  // (the half-step velocity) unless the run predicts the end-of-step velocity for its dashpots. The
  // springs and the energy books always use the ones above.
  Real dashpot_overlap_rate;         // [m/s]
  Vec3 dashpot_tangential_velocity;  // [m/s]
  Vec3 dashpot_rolling_velocity;     // [rad/s]
  bool onset = false;        // the contact's first evaluation, for the energy books
};

/// What the law returns: the force on i (j gets its negative) and the rolling torque on i.
struct ContactResponse {
  Vec3 force;           // [N]
  Vec3 rolling_torque;  // [N m]
  Real normal_force;    // F_n [N], the scalar the friction limits use
  Real power;           // rate of work done by the particles on the contact [W]
  Real elastic;         // energy stored in the contact's springs after the update [J]
  Real normal_power;    // the normal spring-dashpot's part of `power` [W]
  Real normal_elastic;  // the normal spring's part of `elastic` [J]
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

/// The kinetic (sliding or rolling) response: magnitude `limit` against the relative motion `rate`,
/// along the spring's pull when the motion vanishes exactly; the spring is reset to match.
inline Vec3 kinetic_response(Vec3& spring, const Vec3& rate, const Vec3& elastic, Real k, Real limit) {
  const Real rate_norm = rate.norm(), elastic_norm = elastic.norm();
  const Vec3 direction = rate_norm > 0      ? Vec3(-rate / rate_norm)
                         : elastic_norm > 0 ? Vec3(elastic / elastic_norm)
                                            : Vec3(Vec3::Zero());
  const Vec3 response = limit * direction;
  spring = -response / k;
  return response;
}

/// Tangential spring-dashpot-slider (docs/physics.md 2.3, 2.5): while stuck, the spring xi advances by
/// u_t h and the force is -k xi - c u_t; while sliding, F_t = -mu F_n along the slip.
///  - Stick -> slide when the spring force exceeds mu_s F_n, or when the contact slips so fast that
///    the dashpot alone would need more than mu_s F_n (a sphere launched sliding slides at once, not
///    after its spring has wound up at the static force).
///  - Slide -> stick only when the slip reaches zero within the step (u_t turns against the spring)
///    and the spring force is within mu_s F_n; a rise of F_n alone (the normal spring oscillates)
///    must not stick a contact that still slips.
/// Only the spring force decides, not spring plus dashpot (see rolling_spring for why); while stuck
/// the sum is bounded by mu_s F_n, so |F_t| <= mu_s F_n always.
/// `damped_rate` is the slip velocity the dashpot sees (ContactKinematics).
inline Vec3 spring_slider(Vec3& spring, std::uint8_t& mode, const Vec3& rate, const Vec3& damped_rate, Real k, Real c,
                          Real static_limit, Real kinetic_limit, Real h) {
  const bool was_sliding = (mode & mode_sliding) != 0;
  const bool reversed = was_sliding && rate.dot(spring) < 0;
  spring += rate * h;
  Vec3 elastic = -k * spring;
  const Real elastic_norm = elastic.norm();
  const Vec3 viscous = -c * damped_rate;
  const bool hold = elastic_norm <= static_limit && (was_sliding ? reversed : viscous.norm() <= static_limit);
  if (hold) {
    mode = static_cast<std::uint8_t>(mode & ~mode_sliding);
    Vec3 total = elastic + viscous;
    const Real total_norm = total.norm();
    if (total_norm > static_limit) total *= static_limit / total_norm;
    return total;
  }
  mode = static_cast<std::uint8_t>(mode | mode_sliding);
  return kinetic_response(spring, rate, elastic, k, kinetic_limit);
}

/// Rolling resistance (docs/physics.md 2.4, 2.5): a static hold by a rotational spring-dashpot (Ai et al.
/// 2011 model C) and, once rolling, the constant kinetic torque -mu_r R* F_n along omega_r.
/// `inertia` is I* of the relative rotation [kg m^2].
///  - Static -> rolling when the spring torque exceeds the static limit, or when the contact turns so
///    fast that the dashpot alone would need more than the static limit to stop it (the hold cannot be
///    kept: on the seed slope this starts rolling within a few steps, as the constant-torque oracle
///    assumes, instead of after the slow spring has wound up).
///  - Rolling -> static only when omega_r reverses within the step (the roll has stopped); the spring
///    then starts unloaded. A load change alone never ends rolling (that would chatter when
///    mu_r < mu_rs).
///  - Only the spring torque is compared with the static limit, not spring plus dashpot: a suddenly
///    loaded spring-dashpot transmits more than its load for a while (even critically damped), which
///    broke holds that the rigid contact keeps (a sphere set down on a slope, docs/physics.md 8.4). The
///    viscous torque is bounded on its own by the static limit.
/// Stability: forces see the half-step velocity, so a dashpot c alone maps omega_r to
/// (1 - c h / I*) omega_r per step; c is capped at I*/h (deadbeat for one contact); several static
/// contacts on one particle add their c h / I (stable below 2), like the normal dashpots (docs/physics.md 4.2).
/// `damped_rate` is the rolling velocity the dashpot sees (ContactKinematics).
inline Vec3 rolling_spring(Vec3& spring, std::uint8_t& mode, const Vec3& rate, const Vec3& damped_rate, Real k, Real c,
                           Real inertia, Real static_limit, Real kinetic_limit, Real h) {
  const bool was_rolling = (mode & mode_rolling) != 0;
  const bool reversed = was_rolling && rate.dot(spring) < 0;
  spring += rate * h;
  Vec3 elastic = -k * spring;
  const Real elastic_norm = elastic.norm();
  Vec3 viscous = -std::min(c, inertia / h) * damped_rate;
  const Real viscous_norm = viscous.norm();
  const bool hold = was_rolling ? reversed : (elastic_norm <= static_limit && viscous_norm <= static_limit);
  if (hold) {
    mode = static_cast<std::uint8_t>(mode & ~mode_rolling);
    if (was_rolling) {
      // The roll has just stopped: the hold starts unloaded and takes up the torque it needs. Starting
      // from the kinetic torque instead would hand it back and roll the particle backwards (on the seed
      // slope 0.4 R F_n against the 0.2 R F_n gravity needs: 0.1 m/s uphill, ringing for seconds).
      spring.setZero();
      elastic.setZero();
    }
    if (viscous_norm > static_limit) viscous *= static_limit / viscous_norm;
    return elastic + viscous;
  }
  mode = static_cast<std::uint8_t>(mode | mode_rolling);
  return kinetic_response(spring, rate, elastic, k, kinetic_limit);
}

}  // namespace law_detail

template <Separation Sep, bool Friction, RollingKind Rolling>
struct LinearSpringDashpot {
  static constexpr bool friction = Friction;
  static constexpr bool rolling = Rolling != RollingKind::none;
  static constexpr bool uses_rotation = Friction || Rolling != RollingKind::none;

  static ContactResponse evaluate(const LawConstants& c, const ContactKinematics& k, ContactHistory& history,
                                  Real h) {
    ContactResponse out;
    Real fn = c.k_n * k.overlap + c.c_n * k.dashpot_overlap_rate;
    if constexpr (Sep == Separation::force_zero) fn = std::max(fn, Real{0});
    out.normal_force = fn;
    out.force = fn * k.normal;
    out.rolling_torque = Vec3::Zero();
    const Real load = std::max(fn, Real{0});  // friction limits never use an attractive force

    if constexpr (Friction) {
      history.tangential_spring = law_detail::project_keep_length(history.tangential_spring, k.normal);
      out.force += law_detail::spring_slider(history.tangential_spring, history.mode, k.tangential_velocity,
                                             k.dashpot_tangential_velocity, c.k_t, c.c_t, c.mu_s * load, c.mu * load, h);
    }
    if constexpr (Rolling != RollingKind::none) {
      bool active = true;
      if constexpr (Rolling == RollingKind::seed && Friction) active = (history.mode & mode_sliding) == 0;
      if (active) {
        history.rolling_spring = law_detail::project_keep_length(history.rolling_spring, k.normal);
        out.rolling_torque = law_detail::rolling_spring(history.rolling_spring, history.mode, k.rolling_velocity,
                                                        k.dashpot_rolling_velocity, c.k_r, c.c_r, c.i_star,
                                                        c.mu_rs * c.r_star * load, c.mu_r * c.r_star * load, h);
      } else {
        history.rolling_spring.setZero();
        history.mode = static_cast<std::uint8_t>(history.mode | mode_rolling);
      }
    }
    // Energy bookkeeping: the power the particles put into the contact and what its springs hold;
    // their difference, integrated, is what the contact dissipated. Under force_zero a released
    // normal spring (F_n clamped to 0) holds nothing: that energy is lost at the force-zero instant.
    // The force is the mean of its values at the two ends of the step (trapezoid), as velocity Verlet's
    // two half kicks apply it, so the books match the kinetic energy the particles actually exchange:
    // an undamped head-on contact books no dissipation (k (delta0 + delta1) / 2 * h d(delta)/dt is the
    // change of k delta^2 / 2), an elastic stick likewise, and a dashpot whose force jumps from 0 at
    // onset books half its end force over that step, not all of it (the end force alone over-booked
    // c h (d delta / dt)^2 / 2 per impact: 3% of a mill ball's impact energy at t_c / 20).
    // The rolling torque's previous value is not kept: its work uses the end torque.
    const Real previous_normal = k.previous_force.dot(k.normal);
    const Vec3 previous_tangential = k.previous_force - previous_normal * k.normal;
    const Vec3 tangential_force = out.force - fn * k.normal;
    out.normal_power = 0.5 * (previous_normal + fn) * k.overlap_rate;
    // The step on which a contact forms began with the surfaces apart (delta_0 = delta - h d delta/dt
    // < 0): its trapezoid books the spring as k delta (delta - delta_0) / 2, more than the k delta^2 / 2
    // it holds. That excess is velocity Verlet's energy error, not a loss; booked as one it showed
    // every undamped impact as dissipating ~(omega0 h)^2 of its energy, always positive, until the
    // books flagged growth that never happened. So the spring is booked from delta = 0; the
    // dashpot keeps the whole step (what the particles exchange with it). The step on which a
    // contact parts is booked likewise when it leaves the list (contacts.cpp, release_work).
    const bool spring_active = fn > 0 || Sep == Separation::overlap;
    if (k.onset && spring_active && h > 0) {
      const Real start = k.overlap - h * k.overlap_rate;
      if (start < 0) out.normal_power += 0.5 * c.k_n * k.overlap * start / h;
    }
    out.power = out.normal_power - 0.5 * (previous_tangential + tangential_force).dot(k.tangential_velocity);
    if constexpr (Rolling != RollingKind::none) out.power -= out.rolling_torque.dot(k.rolling_velocity);
    out.elastic = spring_active ? 0.5 * c.k_n * k.overlap * k.overlap : 0.0;
    out.normal_elastic = out.elastic;
    if constexpr (Friction) out.elastic += 0.5 * c.k_t * history.tangential_spring.squaredNorm();
    if constexpr (Rolling != RollingKind::none) out.elastic += 0.5 * c.k_r * history.rolling_spring.squaredNorm();
    return out;
  }
};

}  // namespace dem
