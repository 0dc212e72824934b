#pragma once
// The exact tangential and rolling channel of one contact between a particle i and a body j
// (docs/physics.md 2.3-2.5 and 5.6): the spring-slider with static and sliding friction and the rolling
// resistance of contact_law.h (Ai et al. model C static hold, constant kinetic torque), advanced as a
// piecewise linear ODE whose pieces are its modes, split at the mode switches found as roots. j is a wall
// (infinite mass: inverse inertia 0, its spin 0 in its own frame) or a second particle (the velocity is
// then the relative velocity of the centres and the inverse mass 1/m*).
//
// In the tangent plane, with basis e1 and e2 = n x e1, the motion splits into two identical planar
// problems (direction 1 couples the slip along e1 with the spins about e2, direction 2 the slip along
// e2 with minus the spins about e1). Per direction the state is y = (x, v, w_i, w_j, xi, theta):
// tangential displacement, velocity, the two spins, tangential spring and rolling spring, and
//   x' = v,  v' = F/m + g_t,  w_i' = (-a_i F + M)/I_i,  w_j' = (-a_j F - M)/I_j,
//   xi' = u = v - a_i w_i - a_j w_j (stick),  theta' = w_r = w_i - w_j (static),
//   F = -k_t xi - c_t u (stick) or the kinetic -mu F_n u^ (slide),
//   M = -k_r theta - c_r w_r (static), the kinetic -mu_r R* F_n w_r^ (rolling), or 0 (seed mode, sliding).
// (The contact point is at -a_i n from i and +a_j n from j, so both moments of F are -a n x F.)
// In every mode this is y' = A y + b with constant A and b, propagated exactly by the exponential of
// the 10x10 matrix [[A t, B t], [0, R t]] (both directions share A; B holds their forcings, constant and
// growing with time, R makes the ramp). In stick with
// kinetic rolling it is the scalar oscillator of docs/physics.md 5.1 in u with the tangential mass m_t,
// 1/m_t = 1/m + a_i^2/I_i + a_j^2/I_j; with the static hold it is that oscillator coupled to the rolling
// spring. Without rolling resistance the pieces use those closed forms (the scalar propagator in stick,
// a polynomial in slide) instead of the exponential, which then only checks them (TangentialFlow). The moments of F and M on i and j are equal and opposite about the contact point, so the
// flow keeps the angular momentum of the pair (to round-off of the exponential).
// Switches (docs/physics.md 2.5), each a root of a smooth function of time along the exact flow:
//   stick -> slide   |k_t xi| or |c_t u| reaches mu_s F_n (the law's conditions), or the static force
//                    |k_t xi + c_t u| itself does (the law caps it there; a flow slides instead);
//   slide -> stick   the slip u reverses against its direction at the start of the slide;
//   static -> roll   |k_r theta| or |c_r w| reaches mu_rs R* F_n;
//   roll -> static   w reverses against its direction at the start of the roll; the hold starts
//                    unloaded (contact_law.h rolling_spring);
//   seed mode: no rolling torque while sliding (the rolling spring is released).
// Roots are bracketed by sampling at a quarter of the fastest active period, then narrowed to
// round-off (regula falsi with the Illinois rule); the flow continues in the new mode from the root.
// Approximations (docs/physics.md 5.7): the normal force F_n is linear in time and the lever
// arm a constant over a call (the flat wall flow calls this per sub-step with the mean F_n of the exact
// normal flow, so the friction and rolling impulses of a sub-step without switch are exact: mu times the
// normal impulse; the pair and cylinder flows, tangential_kick.h, with a linear fit to it);
// the kinetic directions (slip, rolling) are frozen over a piece: exact for motion in one plane (the seed
// slope); out of it a piece ends where they would turn by 0.2 rad and takes the direction predicted for
// its middle (second order), up to 8 such cuts per call; a crossing of a switching
// threshold and back within one sampling interval is missed; at most max_events switches per call.
// Pure functions: no state, no allocation; safe from any thread.
#include <cstdint>

#include "engine/contact_law.h"
#include "engine/types.h"

namespace dem {

/// Constants of the tangential channel of a particle i on a body j (a wall: inv_inertia_j = 0).
struct TangentialConstants {
  Real inv_mass;     // 1/m of i on a wall, 1/m* of a pair [1/kg]
  Real inv_inertia;  // 1/I_i [1/(kg m^2)]
  Real arm;          // lever arm a_i = R_i - delta/2 [m]
  bool friction;     // the run has a tangential spring-slider
  RollingKind rolling;
  Real k_t, c_t, mu, mu_s;          // [N/m], [N s/m], [-], [-]
  Real k_r, c_r, mu_r, mu_rs;       // [N m/rad], [N m s/rad], [-], [-]
  Real r_star;                      // [m]
  Real inv_inertia_j = 0;           // 1/I_j [1/(kg m^2)]; 0 for a wall
  Real arm_j = 0;                   // lever arm a_j = R_j - delta/2 [m]; unused for a wall
};

/// The particle's motion in the frame of the body j (translating with it; a wall's rotation removed), or
/// for a pair the relative motion of the centres and both spins.
struct TangentialState {
  Vec3 velocity;      // tangential velocity of the centre relative to j [m/s] (no normal component)
  Vec3 spin;          // angular velocity of i relative to the wall, or of i [rad/s] (the part about n is kept)
  Vec3 displacement;  // tangential displacement accumulated by this call [m]
  Vec3 spin_j = Vec3::Zero();  // angular velocity of the partner particle [rad/s]; 0 for a wall
};

/// A mode switch inside a call: its time from the start of the call and the state there.
struct TangentialEvent {
  Real time;             // [s]
  std::uint8_t mode;     // ContactMode bits after the switch
  TangentialState state;
};

struct TangentialEvents {
  static constexpr int capacity = 8;
  int count = 0;
  TangentialEvent event[capacity];
};

/// How a mode piece is propagated: closed forms where the channel is one oscillator or a polynomial (no
/// rolling resistance; the fast path), or the matrix exponential in every mode (an independent check).
enum class TangentialFlow { closed_form, matrix_exponential };

/// Advances the channel over tau [s] under the normal force load + load_rate t [N] (t from the start of the
/// call; kept >= 0) and tangential body acceleration g_t [m/s^2] (perpendicular to the unit normal n,
/// which points into the particle). The kinetic force and torque follow the normal force exactly (its
/// forcing is a ramp in the generator) and so do the static limits the switches are found against.
/// s.displacement is increased by the tangential displacement; history (springs, mode bits) is updated.
/// Returns the energy the channel dissipated [J] (sliding, dashpots, and springs released at switches).
/// `events` (optional) receives the switches, in time order.
Real advance_tangential(const TangentialConstants& c, const Vec3& n, Real load, Real load_rate, const Vec3& g_t,
                        Real tau, TangentialState& s, ContactHistory& history, TangentialEvents* events = nullptr,
                        TangentialFlow kind = TangentialFlow::closed_form);

}  // namespace dem
