#include "engine/exact_stepper.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "engine/contact_law.h"
#include "engine/parallel.h"
#include "engine/tangential_kick.h"

namespace dem {
namespace {

/// The overlap watch looks for the peak inside a step only where the contact's energy could carry it
/// beyond this fraction of the smaller radius (half the divergence limit of engine/cli/energy_audit.h).
constexpr Real watch_depth = 0.25;

constexpr Real never = std::numeric_limits<Real>::infinity();

Vec3 gravity_of(const State& s, ParticleIndex p, const Vec3& g) { return s.inv_mass[p] > 0 ? g : Vec3(Vec3::Zero()); }

/// Free flight of one particle over t (t < 0 runs it backwards); immovable particles feel no gravity.
void free_flight(State& s, ParticleIndex p, const Vec3& g, Real t) {
  const Vec3 gp = gravity_of(s, p, g);
  s.position[p] += s.velocity[p] * t + 0.5 * t * t * gp;
  s.velocity[p] += t * gp;
}

// ---- Events on a free path --------------------------------------------------------------------

/// Real roots of c0 + c1 t + c2 t^2 in ascending order (cancellation-free formula); returns the count.
int quadratic_roots(Real c0, Real c1, Real c2, Real roots[2]) {
  if (c2 == 0) {
    if (c1 == 0) return 0;
    roots[0] = -c0 / c1;
    return 1;
  }
  const Real disc = c1 * c1 - 4 * c2 * c0;
  if (disc < 0) return 0;
  const Real q = -0.5 * (c1 + std::copysign(std::sqrt(disc), c1));
  if (q == 0) {  // c0 = c1 = 0: a double root at 0
    roots[0] = 0;
    return 1;
  }
  roots[0] = std::min(c0 / q, q / c2);
  roots[1] = std::max(c0 / q, q / c2);
  return 2;
}

/// Smallest t in [0, limit] at which c0 + c1 t + c2 t^2 rises through zero, or never.
Real first_rising_root(Real c0, Real c1, Real c2, Real limit) {
  Real roots[2];
  const int count = quadratic_roots(c0, c1, c2, roots);
  for (int k = 0; k < count; ++k)
    if (roots[k] >= 0 && roots[k] <= limit && c1 + 2 * c2 * roots[k] > 0) return roots[k];
  return never;
}

/// The zero of f in [lo, hi], where f is monotone, f(lo) = f_lo and f(hi) has the other sign (or is 0):
/// Newton, bisecting whenever a Newton step would leave the bracket.
template <class F, class DF>
Real monotone_root(const F& f, const DF& df, Real lo, Real hi, Real f_lo) {
  if (f_lo == 0) return lo;
  Real t = lo + 0.5 * (hi - lo);
  for (int k = 0; k < 100; ++k) {
    const Real ft = f(t);
    if (ft == 0) return t;
    if ((ft > 0) == (f_lo > 0)) lo = t;
    else hi = t;
    Real next = t - ft / df(t);
    if (!(next > lo && next < hi)) next = lo + 0.5 * (hi - lo);
    if (next == t) return t;
    t = next;
  }
  return t;
}

/// First time in [0, limit] at which a free path p(t) = r + u t + g t^2 / 2 enters contact, or never:
/// the overlap is sigma (|p| - reach) (sigma = -1: a pair, in contact within reach; +1: the inside of a
/// cylinder, in contact beyond it), and the entry is where it rises through zero (at t = 0 too, for a
/// state touching and moving in). This is the true 3-D path, so a near miss stays a miss at any step.
/// |p|^2 is a quartic in t (a quadratic when g = 0); [0, limit] is cut where its rate has extrema (roots
/// of a quadratic) and where the rate vanishes, so that the overlap is monotone on each piece.
Real first_entry(const Vec3& r, const Vec3& u, const Vec3& g, Real reach, Real sigma, Real limit) {
  const auto at = [&](Real t) { return Vec3(r + t * (u + (0.5 * t) * g)); };
  const auto velocity = [&](Real t) { return Vec3(u + t * g); };
  // The overlap as the flows compute it (so a state touching at t = 0 is judged the same way), and the
  // rate and rate change of sigma |p|^2 / 2, which has the same sign and monotone pieces.
  const auto overlap = [&](Real t) { return sigma * (at(t).norm() - reach); };
  const auto overlap_rate = [&](Real t) { return sigma * at(t).dot(velocity(t)) / at(t).norm(); };
  const auto rate = [&](Real t) { return sigma * at(t).dot(velocity(t)); };
  const auto rate_change = [&](Real t) { return sigma * (velocity(t).squaredNorm() + at(t).dot(g)); };
  Real turns[2], ends[3];
  int end_count = 0;
  const int turn_count = quadratic_roots(u.squaredNorm() + r.dot(g), 3 * u.dot(g), 1.5 * g.squaredNorm(), turns);
  for (int k = 0; k < turn_count; ++k)
    if (turns[k] > 0 && turns[k] < limit) ends[end_count++] = turns[k];
  ends[end_count++] = limit;
  Real knots[7];
  int count = 0;
  knots[count++] = 0;
  Real a = 0, rate_a = rate(0);
  for (int k = 0; k < end_count; ++k) {
    const Real b = ends[k], rate_b = rate(b);
    if ((rate_a < 0 && rate_b > 0) || (rate_a > 0 && rate_b < 0))
      knots[count++] = monotone_root(rate, rate_change, a, b, rate_a);
    knots[count++] = b;
    a = b;
    rate_a = rate_b;
  }
  Real overlap_a = overlap(0);
  for (int k = 0; k + 1 < count; ++k) {
    const Real overlap_b = overlap(knots[k + 1]);
    if (overlap_a <= 0 && overlap_b > 0) return monotone_root(overlap, overlap_rate, knots[k], knots[k + 1], overlap_a);
    overlap_a = overlap_b;
  }
  return never;
}

// ---- The flow of one contact in polar form ------------------------------------------------------

/// Motion of a particle relative to a centre (a pair: the partner, in the relative coordinate) or to an
/// axis (the inside of a cylinder: components across the axis), in a frame where the centre or axis
/// is at rest; the contact force acts along the radial direction e = r / |r|.
struct Radial {
  Vec3 r;      // position from the centre [m]
  Vec3 u;      // velocity [m/s]
  Vec3 g;      // acceleration without the contact (gravity acting on one side only) [m/s^2]
  Real reach;  // contact distance: r_i + r_j, or R_cylinder - r [m]
  Real sigma;  // overlap delta = sigma (|r| - reach): -1 for a pair, +1 inside a cylinder
};

/// The same state as radial direction, velocity across it and the normal coordinate (overlap and its
/// rate); the contact normal, into the particle, is -sigma e.
struct Polar {
  Vec3 e;
  Vec3 u_t;            // [m/s]
  NormalState normal;  // [m], [m/s]
};

Real radius_of(const Radial& x, const NormalState& n) { return x.reach + x.sigma * n.delta; }

Polar polar_of(const Radial& x) {
  const Real rho = x.r.norm();
  const Vec3 e = rho > 0 ? Vec3(x.r / rho) : Vec3(Vec3::UnitX());
  const Real u_e = x.u.dot(e);
  return {e, x.u - u_e * e, {x.sigma * (rho - x.reach), x.sigma * u_e}};
}

void set_cartesian(Radial& x, const Polar& p) {
  x.r = radius_of(x, p.normal) * p.e;
  x.u = (x.sigma * p.normal.rate) * p.e + p.u_t;
}

/// Energy of the normal coordinate per unit m*: relative kinetic + spring (if counted) - work of the forcing.
Real normal_energy(const NormalOscillator& o, Real a, const NormalState& n, bool spring) {
  return 0.5 * n.rate * n.rate + (spring ? 0.5 * o.omega0 * o.omega0 * n.delta * n.delta : 0.0) - a * n.delta;
}

struct Stretch {
  NormalState end;
  Real time;  // [s]
  bool released;
  Real forcing = 0;  // the constant forcing of the normal flow, a of docs/physics.md 5.1 [m/s^2] (contact_stretch)
};

/// The exact normal flow from a pushing state (or one put on the onset condition) over at most `limit`
/// under constant forcing a, cut at the first release. With coefficients for exactly `limit`
/// (`whole_step`: the table's for a stretch over the whole flow, or contact_stretch's own for a short
/// one), advance_normal decides whether the contact releases within it at all (it may skip the search,
/// docs/physics.md 5.2); the release time itself is searched here.
Stretch push(const NormalOscillator& o, Separation sep, Real a, const NormalState& s, Real limit,
             const PropagatorCoefficients* whole_step) {
  const auto at = [&](const PropagatorCoefficients& c) {
    return NormalState{c.phi11 * s.delta + c.phi12 * s.rate + c.gamma1 * a,
                       c.phi21 * s.delta + c.phi22 * s.rate + c.gamma2 * a};
  };
  // A contact that does not push at the end of the step has certainly released within it: no need to
  // ask advance_normal.
  if (whole_step && pushes(o, sep, at(*whole_step))) {
    int events = 0;
    const NormalState end = advance_normal(o, sep, a, s, limit, &events, whole_step);
    if (events == 0) return {end, limit, false};
  }
  const Real release = sep == Separation::force_zero ? force_zero_time(o.omega0, o.beta, s.delta, s.rate, a)
                                                     : overlap_zero_time(o.omega0, o.beta, s.delta, s.rate, a);
  const Real t = std::min(release, limit);
  return {at(propagator(o.omega0, o.beta, t)), t, release < limit};
}

/// One pushing stretch of a contact in polar form, up to its release or `limit`; p is advanced to its
/// end. The radius follows the exact normal flow with the centrifugal term folded into its constant
/// forcing; the velocity across keeps the angular momentum l = rho |u_t| and turns e by
/// l t / (rho0 rho1) (exact when rho is linear in t, second order otherwise). The centrifugal forcing is
/// the discrete gradient sigma l^2 (rho0 + rho1) / (2 rho0^2 rho1^2) of the rotational energy
/// l^2 / (2 rho^2) between the ends, so that energy and angular momentum are both kept to round-off
/// when undamped. Gravity on one side only (an immovable partner, a wall) pushes along the mean of the
/// end directions and kicks u_t by halves before and after the turn, so the stretch stays symmetric in
/// time. The forcing depends on the end, so it is found by fixed-point iteration; it contracts by about
/// (u_t t / rho)^2.
Stretch contact_stretch(ExactInteraction& k, Separation sep, const Radial& x, Polar& p, Real limit,
                        const PropagatorCoefficients* whole_step) {
  const NormalOscillator& o = k.oscillator;
  const Real rho0 = radius_of(x, p.normal);
  const Vec3 e0 = p.e, g_across = x.g - x.g.dot(e0) * e0;
  // The turn over a stretch s: the velocity across after the first half kick, and the end direction.
  struct Turn {
    Vec3 u_t, e;
  };
  const auto turn = [&](const Stretch& s) {
    Turn t{p.u_t + (0.5 * s.time) * g_across, e0};
    const Real speed = t.u_t.norm(), rho1 = radius_of(x, s.end);
    if (speed > 0 && rho0 > 0 && rho1 > 0) {
      const Vec3 across = t.u_t / speed;
      const Real angle = speed * s.time / rho1;
      Real c, sn;
      if (angle < 1e-2) {  // the usual turn within a step: the series is exact to round-off and cheaper
        const Real a2 = angle * angle;
        c = 1 - a2 / 2 * (1 - a2 / 12 * (1 - a2 / 30));
        sn = angle * (1 - a2 / 6 * (1 - a2 / 20 * (1 - a2 / 42)));
      } else {
        c = std::cos(angle), sn = std::sin(angle);
      }
      t.u_t = (speed * rho0 / rho1) * (c * across - sn * e0);
      t.e = c * e0 + sn * across;
    }
    return t;
  };
  const bool gravity_on = x.g != Vec3::Zero();
  const Real speed0 = p.u_t.norm();
  Real a = x.sigma * x.g.dot(e0) + (rho0 > 0 ? x.sigma * speed0 * speed0 / rho0 : 0.0);
  // Without the table, a stretch within advance_normal's quarter period (every piece of split_stretch)
  // gets its own coefficients: they rule out a release without a root search, and the fixed-point
  // iteration below then needs no new flow.
  PropagatorCoefficients own;
  if (!whole_step && limit * o.omega0 <= 0.5 * pi && pushes(o, sep, p.normal)) {
    own = recent_propagator(o.omega0, o.beta, limit);
    whole_step = &own;
  }
  Stretch s = push(o, sep, a, p.normal, limit, whole_step);
  for (int iteration = 0; iteration < 8 && rho0 > 0; ++iteration) {
    const Real rho1 = radius_of(x, s.end);
    if (!(rho1 > 0)) break;
    const Real l = rho0 * (gravity_on ? (p.u_t + (0.5 * s.time) * g_across).norm() : speed0);  // [m^2/s]
    const Real centrifugal = x.sigma * l * l * (rho0 + rho1) / (2 * rho0 * rho0 * rho1 * rho1);
    Real gravity = 0;
    if (gravity_on) {
      const Vec3 mean = e0 + turn(s).e;
      gravity = x.sigma * x.g.dot(mean) / mean.norm();
    }
    const Real next = gravity + centrifugal;
    if (std::abs(next - a) <= 4 * std::numeric_limits<Real>::epsilon() * (std::abs(gravity) + std::abs(centrifugal)))
      break;
    if (whole_step && !s.released) {
      // No event within the step: the end is affine in the forcing (the Gamma column of docs/physics.md
      // 3.1), so the new forcing needs no new flow.
      s.end.delta += whole_step->gamma1 * (next - a);
      s.end.rate += whole_step->gamma2 * (next - a);
    } else {
      s = push(o, sep, next, p.normal, limit, nullptr);
    }
    a = next;
  }
  k.dissipated += k.effective_mass * (normal_energy(o, a, p.normal, true) - normal_energy(o, a, s.end, !s.released));
  const Turn t = turn(s);
  p.e = t.e;
  p.u_t = t.u_t + (0.5 * s.time) * (x.g - x.g.dot(t.e) * t.e);
  watch_overlap(k.watch, o, a, p.normal, s.time, s.end);
  p.normal = s.end;
  s.forcing = a;
  return s;
}

/// The frictionless flows: no tangential channel.
struct NoKick {
  static constexpr bool active = false;
  void operator()(Radial&, const Polar&, Real, Real, Real, Real) const {}
};

/// A tangential channel for radial_flow: a callable f(x, p, duration, elapsed, normal force [N] at the
/// kick's start, its rate [N/s]).
template <class F>
struct Kicking {
  static constexpr bool active = true;
  const F& f;
  void operator()(Radial& x, const Polar& p, Real duration, Real elapsed, Real load, Real load_rate) const {
    f(x, p, duration, elapsed, load, load_rate);
  }
};

bool has_tangential(const ExactSettings& set) { return set.friction || set.rolling != RollingKind::none; }

/// At the release the normal force is zero and so are the friction limits: the law's sliding and rolling
/// responses are zero, their springs reset (contact_law.h), and the springs' energy is dissipated.
void release_springs(ExactInteraction& k) {
  ContactHistory& h = k.history;
  k.dissipated += 0.5 * k.constants.k_t * h.tangential_spring.squaredNorm() +
                  0.5 * k.constants.k_r * h.rolling_spring.squaredNorm();
  h.tangential_spring.setZero();
  h.rolling_spring.setZero();
  h.mode = static_cast<std::uint8_t>(h.mode | mode_sliding | mode_rolling);
}

/// Normal force of the contact in normal state n [N], k delta + c delta', at least 0.
Real normal_force(const ExactInteraction& k, const NormalState& n) {
  const NormalOscillator& o = k.oscillator;
  return std::max(Real{0}, k.effective_mass * (o.omega0 * o.omega0 * n.delta + 2 * o.beta * n.rate));
}

/// One piece of a pushing stretch with the tangential channel split around it, K1(l/2) N(l) K2(l/2): K
/// the kick (tangential_kick.h, geometry frozen), N the exact normal flow in polar form (contact_stretch).
/// The piece is at most a quarter radian of the normal oscillator (or 1/128 of the flow) and ends at the
/// release; both are found first on a copy, with the normal force at the piece's ends and its exact
/// impulse J over the piece (m* times the forcing's change of delta' minus its actual change). The kicks
/// see the normal force of the first and the second half of the piece as lines through its values at
/// the start, the middle and the end (the middle from Simpson's rule on J), scaled so that together they
/// carry J: a slide's friction impulse is mu J, exact (docs/physics.md 5.7), and the static limits follow the
/// force to second order. The approximation is the splitting, second order in the piece: the geometry
/// (normal, lever arms) is frozen in each kick. `elapsed`: time of the piece's start from the start of
/// the flow [s]. The kick changes only the velocity across the normal (and the spins), so the normal
/// state stays the one the normal flow put on its events.
template <class Kick>
Stretch split_stretch(ExactInteraction& k, Separation sep, Radial& x, Polar& p, Real limit, Real tau, Real elapsed,
                      Kick& kick) {
  Real length = std::min(limit, std::max(Real{0.25} / k.oscillator.omega0, tau / 128));
  Real start = normal_force(k, p.normal), middle = start, end = start;  // [N]
  {
    Radial trial_x = x;
    Polar trial_p = p;
    const Real dissipated = k.dissipated;
    const Stretch trial = contact_stretch(k, sep, trial_x, trial_p, length, nullptr);
    k.dissipated = dissipated;
    if (trial.released) length = trial.time;
    if (length > 0) {
      const Real mean = k.effective_mass * (trial.forcing * length - (trial.end.rate - p.normal.rate)) / length;
      end = trial.released ? 0 : normal_force(k, trial.end);
      middle = std::max(Real{0}, (6 * mean - start - end) / 4);
      const Real halves = start + 2 * middle + end;  // 4 / l times the kicks' impulse
      if (halves > 0) {
        const Real scale = std::max(Real{0}, 4 * mean) / halves;
        start *= scale, middle *= scale, end *= scale;
      }
    }
  }
  if (!(length > 0)) return contact_stretch(k, sep, x, p, limit, nullptr);  // releases at once
  const Real half = 0.5 * length;
  const auto kick_half = [&](Real at, Real from, Real to) {
    kick(x, p, half, at, from, (to - from) / half);
    p.u_t = x.u - x.u.dot(p.e) * p.e;
  };
  kick_half(elapsed, start, middle);
  Stretch s = contact_stretch(k, sep, x, p, length, nullptr);
  set_cartesian(x, p);
  if (!s.released && !pushes(k.oscillator, sep, p.normal)) {
    // Cut at the release found on the copy, the piece may end on it or a hair past it: the contact has
    // released, and the normal spring's residual energy is lost there, as contact_stretch books it.
    s.released = true;
    if (p.normal.delta > 0) {
      const Real w = k.oscillator.omega0 * p.normal.delta;
      k.dissipated += k.effective_mass * 0.5 * w * w;
    }
  }
  kick_half(elapsed + s.time, middle, end);
  if (s.released) release_springs(k);
  return s;
}

/// P_k(tau) of the relative motion. Apart: exact free flight, up to an onset found on the true path
/// (first_entry), or, under force_zero with a residual overlap, up to the force rising through zero
/// again (along the normal, to second order). Pushing: contact_stretch. Each stretch ends at an event,
/// so an isolated head-on contact stays exact at any step. With a tangential channel (Kick::active), the
/// pushing stretches are cut into the pieces of split_stretch.
template <class Kick = NoKick>
void radial_flow(Radial& x, ExactInteraction& k, Separation sep, Real tau, const PropagatorCoefficients* whole_step,
                 Kick kick = {}) {
  const NormalOscillator& o = k.oscillator;
  Polar p = polar_of(x);
  bool pushing = pushes(o, sep, p.normal);
  Real left = tau;
  // A contact can only bounce so often within one step; past the cap, events are ignored so the flow
  // always ends (round-off chatter at a graze). A piece of a split stretch that ends without release is
  // not a pass; past max_pieces (round-off stalling a release) the rest of the flow is frictionless.
  constexpr int max_pieces = 4096;
  int pieces = 0;
  for (int pass = 0; left > 0; ++pass) {
    if (pushing) {
      if (Kick::active && pieces++ < max_pieces) {
        const Stretch s = split_stretch(k, sep, x, p, left, tau, tau - left, kick);
        left -= s.time;
        if (!s.released) {
          --pass;
          continue;
        }
      } else {
        const Stretch s = contact_stretch(k, sep, x, p, left, pass == 0 ? whole_step : nullptr);
        set_cartesian(x, p);
        if (!s.released) return;
        left -= s.time;
      }
      pushing = false;
      continue;
    }
    Real t = pass < 16 ? first_entry(x.r, x.u, x.g, x.reach, x.sigma, left) : never;
    bool by_force = false;
    if (pass < 16 && sep == Separation::force_zero && o.beta > 0 && p.normal.delta > 0) {
      // Released with a residual overlap: pressed again when k delta + c delta' rises through zero.
      const Real a = x.sigma * (x.g.dot(p.e) + p.u_t.squaredNorm() / radius_of(x, p.normal));
      const Real w2 = o.omega0 * o.omega0, b2 = 2 * o.beta;
      const NormalState& n = p.normal;
      const Real press = first_rising_root(w2 * n.delta + b2 * n.rate, w2 * n.rate + b2 * a, 0.5 * w2 * a, left);
      if (press < t && n.delta + press * (n.rate + 0.5 * press * a) > 0) t = press, by_force = true;
    }
    const Real flight = std::min(t, left);
    x.r += flight * x.u + (0.5 * flight * flight) * x.g;
    x.u += flight * x.g;
    if (!(t < left)) return;
    left -= flight;
    p = polar_of(x);
    // Put the state exactly on the onset condition, as advance_normal does; a graze (touching without
    // moving in) stays apart.
    if (by_force) p.normal.rate = -o.omega0 * o.omega0 * p.normal.delta / (2 * o.beta);
    else p.normal.delta = 0;
    pushing = by_force || p.normal.rate > 0;
  }
}

/// P_k(tau) for a particle pair: the centre of mass in free flight, the relative motion by radial_flow.
void pair_flow(State& s, ExactInteraction& k, const ExactSettings& set, Real tau) {
  const ParticleIndex i = k.i, j = k.j;
  const Real inv_i = s.inv_mass[i], inv_j = s.inv_mass[j];
  const Vec3 gi = gravity_of(s, i, set.gravity), gj = gravity_of(s, j, set.gravity);
  Radial x{s.position[i] - s.position[j], s.velocity[i] - s.velocity[j], gi - gj, s.radius[i] + s.radius[j], -1};
  if (has_tangential(set)) {
    // The tangential channel acts on the relative velocity and both spins; the normal is e, from j to i.
    const auto kick = [&](Radial& r, const Polar& p, Real duration, Real, Real load, Real load_rate) {
      const Real delta = p.normal.delta;
      const KickBodies bodies{inv_i + inv_j, s.inv_inertia[i], s.inv_inertia[j], s.radius[i] - 0.5 * delta,
                              s.radius[j] - 0.5 * delta};
      k.dissipated += tangential_kick(k.constants, set.friction, set.rolling, bodies, p.e, load, load_rate, duration,
                                      r.u, s.angular_velocity[i], s.angular_velocity[j], k.history);
    };
    radial_flow(x, k, set.separation, tau, nullptr, Kicking<decltype(kick)>{kick});
    if (!(x.reach - x.r.norm() > 0)) k.history = ContactHistory{};  // the record lasts while the overlap does
  } else {
    radial_flow(x, k, set.separation, tau, k.half_step);
  }
  // Centre of mass, weighted by the masses (an immovable partner carries it).
  const Real w_i = inv_i / (inv_i + inv_j), w_j = inv_j / (inv_i + inv_j);
  const Vec3 x_cm = w_j * s.position[i] + w_i * s.position[j];
  const Vec3 v_cm = w_j * s.velocity[i] + w_i * s.velocity[j];
  const Vec3 g_cm = w_j * gi + w_i * gj;
  const Vec3 x_cm_new = x_cm + tau * v_cm + (0.5 * tau * tau) * g_cm;
  const Vec3 v_cm_new = v_cm + tau * g_cm;
  s.position[i] = x_cm_new + w_i * x.r;
  s.position[j] = x_cm_new - w_j * x.r;
  s.velocity[i] = v_cm_new + w_i * x.u;
  s.velocity[j] = v_cm_new - w_j * x.u;
}

/// A flat wall feature (plane, box face) in the frame moving with the wall's velocity at the contact
/// point, frozen over tau: the normal does not turn, so the exact normal flow is the whole normal flow.
/// With friction or rolling resistance the tangential and rolling channel follows exact_friction.h
/// over sub-steps of at most half a radian of the normal oscillator, each under its mean normal force.
/// Returns the frame's velocity.
Vec3 flat_wall_flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau,
                    const WallTouch& t, Real pad, Real start_time) {
  const ParticleIndex p = k.i;
  const Vec3 g = gravity_of(s, p, set.gravity);
  const Vec3 n = t.normal;
  const Real overlap = t.overlap - pad;
  const Vec3 v_wall = walls.velocity_at(k.wall, s.position[p] - (s.radius[p] - 0.5 * overlap) * n);
  const Vec3 u = s.velocity[p] - v_wall;
  const NormalState start{overlap, -u.dot(n)};
  const Real a = -g.dot(n);
  const NormalOscillator& o = k.oscillator;
  const Vec3 u_t = u + start.rate * n;
  const Vec3 g_t = g - g.dot(n) * n;
  if (!set.friction && set.rolling == RollingKind::none) {
    const NormalState after = advance_normal(o, set.separation, a, start, tau, nullptr, k.half_step, &k.watch);
    k.dissipated += k.effective_mass * (normal_energy(o, a, start, pushes(o, set.separation, start)) -
                                        normal_energy(o, a, after, pushes(o, set.separation, after)));
    s.position[p] += tau * v_wall + (start.delta - after.delta) * n + tau * u_t + (0.5 * tau * tau) * g_t;
    s.velocity[p] = v_wall - after.rate * n + u_t + tau * g_t;
    return v_wall;
  }
  // With friction the frame moves with the wall's material at the particle's centre and the spin is taken
  // against the wall's: the slip v - v_wall(contact) - a w x n of contact_law.h (the frame at the contact
  // point would be off by a w_wall x n on a rotating wall). Its normal velocity is the contact point's.
  const Vec3 w_wall = walls.angular_velocity(k.wall);
  const Vec3 v_frame = walls.velocity_at(k.wall, s.position[p]);
  const Vec3 spin_before = s.angular_velocity[p];
  const LawConstants& lc = k.constants;
  TangentialConstants c{s.inv_mass[p], s.inv_inertia[p], s.radius[p], set.friction, set.rolling,
                        lc.k_t, lc.c_t, lc.mu, lc.mu_s, lc.k_r, lc.c_r, lc.mu_r, lc.mu_rs, lc.r_star};
  const Vec3 u_frame = s.velocity[p] - v_frame;
  TangentialState ts{Vec3(u_frame - u_frame.dot(n) * n), s.angular_velocity[p] - w_wall, Vec3::Zero()};
  const Vec3 x0 = s.position[p];
  const int pieces = std::clamp(static_cast<int>(std::ceil(tau * o.omega0 / 0.5)), 1, 64);
  const Real piece = tau / pieces;
  NormalState ns = start;
  for (int j = 0; j < pieces; ++j) {
    const NormalState ne = advance_normal(o, set.separation, a, ns, piece, nullptr, nullptr, &k.watch);
    // The mean normal force over the sub-step from its exact impulse: m* (a t - change of delta').
    const Real load = std::max(Real{0}, k.effective_mass * (a * piece - (ne.rate - ns.rate)) / piece);
    c.arm = s.radius[p] - 0.5 * std::max(Real{0}, 0.5 * (ns.delta + ne.delta));
    TangentialEvents events;
    k.dissipated += advance_tangential(c, n, load, 0, g_t, piece, ts, k.history, &events);
    for (int e = 0; e < events.count; ++e) {
      const TangentialEvent& ev = events.event[e];
      const Real since = j * piece + ev.time;
      const NormalState at = advance_normal(o, set.separation, a, ns, ev.time);
      if (k.event_count < ExactInteraction::event_capacity)
        k.events[k.event_count] = {start_time + since, p, k.wall, ev.mode,
                                   x0 + since * v_frame + (start.delta - at.delta) * n + ev.state.displacement,
                                   v_frame - at.rate * n + ev.state.velocity, w_wall + ev.state.spin};
      ++k.event_count;
    }
    ns = ne;
  }
  const NormalState& after = ns;
  k.dissipated += k.effective_mass * (normal_energy(o, a, start, pushes(o, set.separation, start)) -
                                      normal_energy(o, a, after, pushes(o, set.separation, after)));
  s.position[p] += tau * v_frame + (start.delta - after.delta) * n + ts.displacement;
  s.velocity[p] = v_frame - after.rate * n + ts.velocity;
  s.angular_velocity[p] = w_wall + ts.spin;
  // The wall's spin against the contact's angular impulse (its translation's work is booked by wall_flow).
  k.work += w_wall.dot(s.angular_velocity[p] - spin_before) / s.inv_inertia[p];
  // The record lasts while the geometric overlap does (docs/physics.md 2.1).
  if (!(after.delta > 0)) k.history = ContactHistory{};
  return v_frame;
}

/// The inside of a cylinder, in the frame of its axis (where the shell is at rest: a spin about its own
/// axis does not move it; any other rotation is frozen over tau): along the axis free flight, across
/// it the polar flow of the pair, the axis as centre, so the normal turns with the motion around it.
/// Returns the frame's velocity.
Vec3 cylinder_flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau) {
  const ParticleIndex p = k.i;
  const Vec3 g = gravity_of(s, p, set.gravity);
  const Vec3 axis = walls.rotation(k.wall) * walls.config(k.wall).axis;
  const Real along = (s.position[p] - walls.point(k.wall)).dot(axis);
  const Vec3 centre = walls.point(k.wall) + along * axis;
  const Vec3 v_frame = walls.velocity_at(k.wall, centre);
  const Vec3 u = s.velocity[p] - v_frame;
  const Real u_along = u.dot(axis), g_along = g.dot(axis);
  const Real reach = walls.config(k.wall).radius - s.radius[p];
  Radial x{s.position[p] - centre, u - u_along * axis, g - g_along * axis, reach, 1};
  if (!has_tangential(set)) {
    radial_flow(x, k, set.separation, tau, k.half_step);
    s.position[p] = centre + tau * v_frame + (tau * u_along + 0.5 * tau * tau * g_along) * axis + x.r;
    s.velocity[p] = v_frame + (u_along + tau * g_along) * axis + x.u;
    return v_frame;
  }
  // The tangential channel against the shell's material, whose spin w_wall (frozen over tau) moves it at
  // w_wall x r across the axis frame. The tangent plane holds the axis, so a kick also changes the speed
  // along it: kept apart (du_along) with the displacement it adds until the end of the flow.
  const Vec3 w_wall = walls.angular_velocity(k.wall);
  const Real mass = 1 / s.inv_mass[p], inertia = 1 / s.inv_inertia[p];
  Real du_along = 0, shift_along = 0;
  const auto kick = [&](Radial& r, const Polar& polar, Real duration, Real elapsed, Real load, Real load_rate) {
    const Vec3 shell = w_wall.cross(r.r);
    const Vec3 axial = (u_along + du_along + elapsed * g_along) * axis;
    Vec3 relative = r.u + axial - shell, spin = s.angular_velocity[p] - w_wall, none = Vec3::Zero();
    const Vec3 relative_before = relative, spin_before = spin;
    const KickBodies bodies{s.inv_mass[p], s.inv_inertia[p], 0, s.radius[p] - 0.5 * polar.normal.delta, 0};
    k.dissipated += tangential_kick(k.constants, set.friction, set.rolling, bodies, -polar.e, load, load_rate,
                                    duration, relative, spin, none, k.history);
    const Vec3 dv = relative - relative_before;
    const Real dv_along = dv.dot(axis);
    du_along += dv_along;
    shift_along += dv_along * (tau - elapsed);
    r.u += dv - dv_along * axis;
    s.angular_velocity[p] = w_wall + spin;
    // The shell's work beyond the frame's translation (wall_flow books that part): its surface speed
    // against the tangential impulse and its spin against the contact's angular impulse.
    k.work += mass * shell.dot(dv) + inertia * w_wall.dot(spin - spin_before);
  };
  radial_flow(x, k, set.separation, tau, nullptr, Kicking<decltype(kick)>{kick});
  s.position[p] = centre + tau * v_frame + (tau * u_along + 0.5 * tau * tau * g_along + shift_along) * axis + x.r;
  s.velocity[p] = v_frame + (u_along + du_along + tau * g_along) * axis + x.u;
  if (!(x.r.norm() - reach > 0)) k.history = ContactHistory{};  // the record lasts while the overlap does
  return v_frame;
}

/// P_k(tau) for a particle against a wall (infinite mass). Also books the work the wall did on the
/// particle: the frame's velocity times the contact impulse m (dv - g tau), exact for the flow's wall.
void wall_flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau,
               Real start_time) {
  const ParticleIndex p = k.i;
  const Vec3 g = gravity_of(s, p, set.gravity);
  const Real r = s.radius[p];
  const Vec3 v0 = s.velocity[p];
  // Geometry with a padded radius: beyond the pad the particle cannot reach the wall within tau (its
  // speed relative to the wall, which may be moving towards it).
  const Real pad = r + (v0 - walls.velocity_at(k.wall, s.position[p])).norm() * tau + 0.5 * g.norm() * tau * tau;
  WallTouch t;
  if (!walls.touch(k.wall, k.feature, s.position[p], r + pad, t)) {
    free_flight(s, p, set.gravity, tau);
    k.history = ContactHistory{};  // no overlap: the record ends
    return;
  }
  const Vec3 v_frame = walls.config(k.wall).kind == WallKind::cylinder ? cylinder_flow(s, walls, k, set, tau)
                                                                       : flat_wall_flow(s, walls, k, set, tau, t, pad, start_time);
  k.work += v_frame.dot((s.velocity[p] - v0) - tau * g) / s.inv_mass[p];
}

/// P_k(tau) from start_time [s] (the time the flow's start state belongs to, for the mode events).
void flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau, Real start_time) {
  if (k.wall == ExactInteraction::no_wall) pair_flow(s, k, set, tau);
  else wall_flow(s, walls, k, set, tau, start_time);
}

/// Free drift of the particles of interaction k over t.
void drift(State& s, const ExactInteraction& k, const Vec3& g, Real t) {
  free_flight(s, k.i, g, t);
  if (k.wall == ExactInteraction::no_wall) free_flight(s, k.j, g, t);
}

NormalOscillator oscillator_of(const LawConstants& c, Real m_star) {
  return {std::sqrt(c.k_n / m_star), c.c_n / (2 * m_star)};
}

/// The interactions of this step: candidate pairs and wall features that can touch within h.
/// Key of an interaction for the sorted `forced` list: particle, then partner slot or wall feature.
std::uint64_t interaction_key(ParticleIndex a, std::uint64_t partner) { return (std::uint64_t{a} << 32) | partner; }
std::uint64_t wall_partner(std::size_t w, std::uint32_t f) {
  return 0x80000000u | wall_feature_code(static_cast<std::uint32_t>(w), f);
}

bool forced_contains(const std::vector<std::uint64_t>& forced, std::uint64_t key) {
  return std::binary_search(forced.begin(), forced.end(), key);
}

/// The history a contact carried out of the previous step, or a fresh one.
ContactHistory history_of(const ExactWorkspace& work, std::uint64_t key) {
  const auto it = std::lower_bound(work.history.begin(), work.history.end(), key,
                                   [](const ExactHistoryRecord& r, std::uint64_t x) { return r.key < x; });
  return it != work.history.end() && it->key == key ? it->history : ContactHistory{};
}

/// A pair's history seen from the other side: the springs (relative motion of i against j) change sign.
ContactHistory flipped(ContactHistory h, bool flip) {
  if (flip) {
    h.tangential_spring = -h.tangential_spring;
    h.rolling_spring = -h.rolling_spring;
  }
  return h;
}

void collect_interactions(const State& s, const Walls& walls, const MaterialTable& materials,
                          const broadphase::CandidatePairs& candidates, const ExactSettings& set, Real h,
                          ExactWorkspace& work) {
  const std::size_t n = s.size();
  auto pair_interacts = [&](ParticleIndex a, ParticleIndex b) {
    if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) return false;
    if (forced_contains(work.forced, interaction_key(a, b))) return true;
    const Real gap = (s.position[a] - s.position[b]).norm() - s.radius[a] - s.radius[b];
    const Vec3 dg = gravity_of(s, a, set.gravity) - gravity_of(s, b, set.gravity);
    return gap <= anticipation_factor * ((s.velocity[a] - s.velocity[b]).norm() * h + 0.5 * dg.norm() * h * h);
  };
  // Features of wall w particle p interacts with, ascending: those its sphere padded by the reach of
  // the step touches, and the forced ones. Through touching_features, never a loop over all feature
  // ids (a mesh wall has thousands).
  auto wall_features = [&](ParticleIndex p, std::size_t w, std::vector<std::uint32_t>& out) {
    out.clear();
    if (s.inv_mass[p] == 0) return;
    const Real reach = anticipation_factor * ((s.velocity[p] - walls.velocity_at(w, s.position[p])).norm() * h +
                                              0.5 * set.gravity.norm() * h * h);
    out.resize(walls.touching_count(w, s.position[p], s.radius[p] + reach));
    walls.touching_features(w, s.position[p], s.radius[p] + reach, out.data());
    const auto first = std::lower_bound(work.forced.begin(), work.forced.end(), interaction_key(p, wall_partner(w, 0)));
    const auto last = std::upper_bound(first, work.forced.end(), interaction_key(p, wall_partner(w, max_wall_features - 1)));
    if (first == last) return;
    const std::size_t touched = out.size();
    for (auto it = first; it != last; ++it) out.push_back(static_cast<std::uint32_t>(*it) & (max_wall_features - 1));
    std::inplace_merge(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(touched), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  };
  work.count.assign(n, 0);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t c = 0;
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k)
      c += pair_interacts(static_cast<ParticleIndex>(a), candidates.partner[k]) ? 1 : 0;
    thread_local std::vector<std::uint32_t> features;
    for (std::size_t w = 0; w < walls.count(); ++w) {
      wall_features(static_cast<ParticleIndex>(a), w, features);
      c += static_cast<std::uint32_t>(features.size());
    }
    work.count[a] = c;
  });
  exclusive_scan(work.count, work.offset);
  work.interactions.resize(work.offset[n]);
  parallel_for(n, [&](std::size_t a0) {
    const auto a = static_cast<ParticleIndex>(a0);
    std::uint32_t slot = work.offset[a];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      if (!pair_interacts(a, b)) continue;
      const EffectiveMasses m =
          effective_masses(s.inv_mass[a], s.inv_inertia[a], s.radius[a], s.inv_mass[b], s.inv_inertia[b], s.radius[b]);
      const LawConstants c = materials.constants(materials.pair_class(s.material[a], s.material[b]), m);
      const ContactHistory history =
          set.friction || set.rolling != RollingKind::none
              ? flipped(history_of(work, exact_pair_history_key(s.id[a], s.id[b])), s.id[a] > s.id[b])
              : ContactHistory{};
      work.interactions[slot++] = {a, b, ExactInteraction::no_wall, 0, oscillator_of(c, m.m_star), c.k_n, m.m_star, 0, 0,
                                   nullptr, c, history, 0, {}, {watch_depth * std::min(s.radius[a], s.radius[b]), 0}};
    }
    thread_local std::vector<std::uint32_t> features;
    for (std::size_t w = 0; w < walls.count(); ++w) {
      wall_features(a, w, features);
      for (const std::uint32_t f : features) {
        const EffectiveMasses m = effective_masses(s.inv_mass[a], s.inv_inertia[a], s.radius[a], 0, 0,
                                                   std::numeric_limits<Real>::infinity());
        const LawConstants c = materials.constants(materials.pair_class(s.material[a], walls.material(w)), m);
        work.interactions[slot++] = {a, a, static_cast<std::uint32_t>(w), f, oscillator_of(c, m.m_star), c.k_n,
                                     m.m_star, 0, 0, nullptr, c, history_of(work, exact_history_key(s.id[a], w, f)),
                                     0, {}, {watch_depth * s.radius[a], 0}};
      }
    }
  });
}

}  // namespace

namespace {

/// The deepest overlap reached inside the step by any interaction, over the smaller radius involved.
Worst deepest_interaction(const State& s, const std::vector<ExactInteraction>& interactions) {
  Worst worst;
  for (const ExactInteraction& k : interactions) {  // a maximum: exact in any order
    const bool pair = k.wall == ExactInteraction::no_wall;
    const Real radius = pair ? std::min(s.radius[k.i], s.radius[k.j]) : s.radius[k.i];
    const ParticleId partner = pair ? s.id[k.j] : s.id[k.i];
    worst = Worst::worse(worst, Worst{std::min(s.id[k.i], partner), std::max(s.id[k.i], partner), k.watch.deepest / radius, 0});
  }
  return worst;
}

}  // namespace

Real max_free_displacement(const State& s, const Vec3& gravity, Real h) {
  Real largest = 0;  // a maximum is exact in any order
  for (std::size_t p = 0; p < s.size(); ++p)
    largest = std::max(largest, s.velocity[p].norm() * h + (s.inv_mass[p] > 0 ? 0.5 * gravity.norm() * h * h : 0.0));
  return largest;
}

namespace {

std::uint64_t key_of(const ExactInteraction& k) {
  return interaction_key(k.i, k.wall == ExactInteraction::no_wall ? std::uint64_t{k.j} : wall_partner(k.wall, k.feature));
}

/// Contacts touching at the end of a step that were not among its interactions (so no force acted
/// on them), appended to `missed` as sorted interaction keys. The interactions of row a lie in
/// [offset[a], offset[a+1]) in ascending key order (pairs by partner, then walls), so each row is
/// checked on its own, in parallel; the rare list of misses is then built serially.
void find_missed(const State& s, const Walls& walls, const broadphase::CandidatePairs& candidates,
                 const ExactWorkspace& work, std::vector<std::uint64_t>& missed) {
  auto missed_in_row = [&](std::size_t a, std::vector<std::uint64_t>* out) {
    const auto first = work.interactions.begin() + work.offset[a], last = work.interactions.begin() + work.offset[a + 1];
    bool any = false;
    auto check = [&](std::uint64_t key) {
      const auto it = std::lower_bound(first, last, key, [](const ExactInteraction& k, std::uint64_t x) { return key_of(k) < x; });
      if (it != last && key_of(*it) == key) return;
      any = true;
      if (out) out->push_back(key);
    };
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      const Real reach = s.radius[a] + s.radius[b];
      if ((s.inv_mass[a] > 0 || s.inv_mass[b] > 0) && (s.position[a] - s.position[b]).squaredNorm() < reach * reach)
        check(interaction_key(static_cast<ParticleIndex>(a), b));
    }
    thread_local std::vector<std::uint32_t> features;
    for (std::size_t w = 0; w < walls.count() && s.inv_mass[a] > 0; ++w) {
      features.resize(walls.touching_count(w, s.position[a], s.radius[a]));
      walls.touching_features(w, s.position[a], s.radius[a], features.data());
      for (const std::uint32_t f : features) check(interaction_key(static_cast<ParticleIndex>(a), wall_partner(w, f)));
    }
    return any;
  };
  if (!parallel_any(s.size(), [&](std::size_t a) { return missed_in_row(a, nullptr); })) return;
  for (std::size_t a = 0; a < s.size(); ++a) missed_in_row(a, &missed);
}

Real compose(State& s, Walls& walls, const ExactSettings& set, Real t, Real h, ExactWorkspace& work);

/// After an accepted step: the contacts' histories for the next step, keyed by particle ids (the
/// interactions are in slot order, which is id order unless the slots were permuted: then sorted), and
/// their mode switches appended in time order if recorded. Serial.
void keep_histories(const State& s, ExactWorkspace& work) {
  work.history.clear();
  const std::size_t first_event = work.events.size();
  for (const ExactInteraction& k : work.interactions) {
    const ContactHistory& h = k.history;
    const Real elastic = 0.5 * k.constants.k_t * h.tangential_spring.squaredNorm() +
                         0.5 * k.constants.k_r * h.rolling_spring.squaredNorm();
    const bool kept = h.mode != 0 || h.tangential_spring != Vec3::Zero() || h.rolling_spring != Vec3::Zero();
    if (k.wall == ExactInteraction::no_wall) {
      if (kept)
        work.history.push_back(
            {exact_pair_history_key(s.id[k.i], s.id[k.j]), flipped(h, s.id[k.i] > s.id[k.j]), elastic});
      continue;
    }
    if (kept) work.history.push_back({exact_history_key(s.id[k.i], k.wall, k.feature), h, elastic});
    if (work.record_events)
      for (int e = 0; e < std::min<int>(k.event_count, ExactInteraction::event_capacity); ++e)
        work.events.push_back(k.events[e]);
  }
  const auto by_key = [](const ExactHistoryRecord& x, const ExactHistoryRecord& y) { return x.key < y.key; };
  if (!std::is_sorted(work.history.begin(), work.history.end(), by_key))
    std::sort(work.history.begin(), work.history.end(), by_key);  // keys are unique: one order for any input
  std::stable_sort(work.events.begin() + static_cast<std::ptrdiff_t>(first_event), work.events.end(),
                   [](const ExactModeEvent& x, const ExactModeEvent& y) { return x.time < y.time; });
}

std::uint64_t bits_of(Real x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

/// Points every interaction at the table's coefficients for its oscillator over tau (serial: the
/// table inserts; the flows then only read).
void attach_coefficients(ExactWorkspace& work, Real tau) {
  if (work.table_step != tau || work.class_of.size() > ExactWorkspace::table_capacity) {
    work.class_of.clear();
    work.table.clear();
    work.table_step = tau;
  }
  for (ExactInteraction& k : work.interactions) {
    const auto key = std::make_pair(bits_of(k.oscillator.omega0), bits_of(k.oscillator.beta));
    const auto [it, inserted] = work.class_of.try_emplace(key, static_cast<std::uint32_t>(work.class_of.size()));
    (void)inserted;
    k.half_step = &work.table.get(it->second, 0, k.oscillator.omega0, k.oscillator.beta, tau);
  }
}

}  // namespace

Real exact_step(State& s, Walls& walls, const MaterialTable& materials,
                const broadphase::CandidatePairs& candidates, const ExactSettings& settings, Real t, Real h,
                ExactWorkspace& work) {
  ExactSettings set = settings;
  set.friction = materials.any_friction();
  set.rolling = materials.any_rolling() ? work.rolling : RollingKind::none;
  const bool tangential = set.friction || set.rolling != RollingKind::none;
  // A contact that the anticipation missed (another contact changed a velocity within the step)
  // would start the next step overlapped, with energy from nothing: redo the step from the saved
  // state with the missed contacts included, until none is missed.
  work.saved_position = s.position;
  work.saved_velocity = s.velocity;
  if (tangential) work.saved_angular_velocity = s.angular_velocity;
  work.forced.clear();
  for (int attempt = 0;; ++attempt) {
    walls.set_time(t);
    collect_interactions(s, walls, materials, candidates, set, h, work);
    if (set.use_table) attach_coefficients(work, 0.5 * h);
    const Real dissipated = compose(s, walls, set, t, h, work);
    walls.set_time(t + h);
    std::vector<std::uint64_t> missed;
    find_missed(s, walls, candidates, work, missed);
    if (!missed.empty() && attempt < work.max_retries) {
      work.forced.insert(work.forced.end(), missed.begin(), missed.end());
      std::sort(work.forced.begin(), work.forced.end());
      s.position = work.saved_position;
      s.velocity = work.saved_velocity;
      if (tangential) s.angular_velocity = work.saved_angular_velocity;
      ++work.retries;
      continue;
    }
    // Out of retries: accept, but never silently.
    if (!missed.empty()) ++work.unresolved;
    work.wall_work +=
        block_sum<Real>(work.interactions.size(), [&](std::size_t k) { return work.interactions[k].work; });
    work.deepest = deepest_interaction(s, work.interactions);
    if (tangential) keep_histories(s, work);
    return dissipated;
  }
}

namespace {

Real compose(State& s, Walls& walls, const ExactSettings& set, Real t, Real h, ExactWorkspace& work) {
  // Colour the interaction graph; a wall contact is an edge to a node of its own.
  const std::size_t n = s.size(), m = work.interactions.size();
  work.edge_i.resize(m);
  work.edge_j.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const ExactInteraction& x = work.interactions[k];
    work.edge_i[k] = x.i;
    work.edge_j[k] = x.wall == ExactInteraction::no_wall ? x.j : static_cast<ParticleIndex>(n + k);
  }
  color_contacts(n + m, work.edge_i, work.edge_j, work.coloring);
  const ContactColoring& col = work.coloring;
  const Real half = 0.5 * h;
  auto colour = [&](std::size_t c, bool adjoint) {
    parallel_for(col.start[c + 1] - col.start[c], [&](std::size_t e) {
      ExactInteraction& k = work.interactions[col.contact[col.start[c] + e]];
      if (adjoint) {
        drift(s, k, set.gravity, -half);
        flow(s, walls, k, set, half, t + half);
      } else {
        flow(s, walls, k, set, half, t);
        drift(s, k, set.gravity, -half);
      }
    });
  };
  // Each sweep's wall flows cover half a step from its start: walls at their pose at t, then t + h/2.
  walls.set_time(t);
  for (std::size_t c = 0; c < col.color_count(); ++c) colour(c, false);
  parallel_for(n, [&](std::size_t p) { free_flight(s, static_cast<ParticleIndex>(p), set.gravity, h); });
  walls.set_time(t + half);
  for (std::size_t c = col.color_count(); c-- > 0;) colour(c, true);
  if (set.dimension == 2)
    parallel_for(n, [&](std::size_t p) {
      s.position[p].z() = 0;
      s.velocity[p].z() = 0;
    });
  return block_sum<Real>(m, [&](std::size_t k) { return work.interactions[k].dissipated; });
}

}  // namespace
}  // namespace dem
