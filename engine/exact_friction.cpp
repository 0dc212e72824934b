#include "engine/exact_friction.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "engine/propagator.h"

namespace dem {
namespace {

constexpr int rows = 6;  // per direction: x, v, w_i, w_j, xi, theta
using Mat = Eigen::Matrix<Real, rows + 4, rows + 4>;  // and per direction a constant input and a ramp t
using Planar = Eigen::Matrix<Real, rows, 2>;  // columns: directions 1 and 2
using Vec2 = Eigen::Matrix<Real, 2, 1>;
enum Row { X = 0, V = 1, W = 2, WJ = 3, XI = 4, TH = 5 };
constexpr int forcing = rows;    // first column of the constant forcings
constexpr int ramp = rows + 2;   // first column of the forcings growing with the time t since the piece's start

/// exp(m) by scaling and squaring with a Taylor polynomial of degree 18 on norm <= 1/2 (truncation
/// below 1e-21 relative): deterministic and good to round-off for the small, stable systems here.
Mat exponential(const Mat& m) {
  const Real norm = m.cwiseAbs().rowwise().sum().maxCoeff();
  int squarings = 0;
  if (norm > 0.5) squarings = std::min(1000, static_cast<int>(std::ceil(std::log2(norm / 0.5))));
  const Mat a = std::ldexp(Real{1}, -squarings) * m;
  Mat result = Mat::Identity(), term = Mat::Identity();
  // Coefficient-wise (lazy) products: at this size Eigen's blocked product would pack the operands first.
  for (int k = 1; k <= 18; ++k) {
    const Mat next = term.lazyProduct(a);  // lazy products must not write into an operand
    term = next / static_cast<Real>(k);
    result += term;
  }
  for (int k = 0; k < squarings; ++k) {
    const Mat square = result.lazyProduct(result);
    result = square;
  }
  return result;
}

/// One mode piece: which springs act and the frozen directions of the kinetic force and torque.
struct Piece {
  bool stick = false;  // tangential spring-dashpot acts (else the kinetic force, possibly 0)
  bool hold = false;   // rolling spring-dashpot acts (else the kinetic torque, possibly 0)
  Vec2 slide = Vec2::Zero();  // unit slip direction the kinetic force -mu F_n opposes (planar)
  Vec2 roll = Vec2::Zero();   // unit rolling direction the kinetic torque opposes (planar)
};

struct Limits {
  Real stick, slide, hold, roll;  // mu_s F_n, mu F_n, mu_rs R* F_n, mu_r R* F_n
};

Limits limits(const TangentialConstants& c, Real f_n) {
  return {c.mu_s * f_n, c.mu * f_n, c.mu_rs * c.r_star * f_n, c.mu_r * c.r_star * f_n};
}

Vec2 slip(const TangentialConstants& c, const Planar& y) {
  return Vec2(y.row(V).transpose() - c.arm * y.row(W).transpose() - c.arm_j * y.row(WJ).transpose());
}

/// Relative rolling velocity w_r = w_i - w_j (planar).
Vec2 rolling_rate(const Planar& y) { return Vec2(y.row(W).transpose() - y.row(WJ).transpose()); }

Vec2 unit(const Vec2& v) {
  const Real norm = v.norm();
  return norm > 0 ? Vec2(v / norm) : Vec2(Vec2::Zero());
}

bool rolling_active(const TangentialConstants& c, std::uint8_t mode) {
  if (c.rolling == RollingKind::none) return false;
  return !(c.rolling == RollingKind::seed && c.friction && (mode & mode_sliding));
}

/// Mode corrections at the start of a call, as the law decides them from the state (a new contact,
/// or a load that changed between sub-steps). The tolerance keeps a state put on a threshold by a
/// root in the previous call from switching again.
void settle(const TangentialConstants& c, const Limits& lim, Planar& y, std::uint8_t& mode) {
  constexpr Real tol = 1 + 1e-12;
  if (c.friction) {
    const Vec2 xi = y.row(XI).transpose(), slip_velocity = slip(c, y);
    const Real spring = c.k_t * xi.norm(), u = slip_velocity.norm();
    if (!(mode & mode_sliding)) {
      const Real force = Vec2(c.k_t * xi + c.c_t * slip_velocity).norm();  // the static force
      if (!(lim.stick > 0) || spring > tol * lim.stick || c.c_t * u > tol * lim.stick || force > tol * lim.stick)
        mode |= mode_sliding;
    } else if (u == 0 && lim.stick > 0 && spring <= lim.stick) {
      mode &= static_cast<std::uint8_t>(~mode_sliding);
    }
  } else {
    mode |= mode_sliding;
    y.row(XI).setZero();
  }
  if (c.rolling == RollingKind::none) return;
  if (!rolling_active(c, mode)) {
    mode |= mode_rolling;
    y.row(TH).setZero();
    return;
  }
  const Real w = rolling_rate(y).norm();
  if (!(mode & mode_rolling)) {
    const Real spring = c.k_r * Vec2(y.row(TH).transpose()).norm();
    if (!(lim.hold > 0) || spring > tol * lim.hold || c.c_r * w > tol * lim.hold) mode |= mode_rolling;
  } else if (w == 0 && lim.hold > 0) {
    mode &= static_cast<std::uint8_t>(~mode_rolling);
    y.row(TH).setZero();
  }
}

Piece piece_of(const TangentialConstants& c, const Planar& y, std::uint8_t mode) {
  Piece p;
  p.stick = c.friction && !(mode & mode_sliding);
  if (c.friction && !p.stick) {
    const Vec2 u = slip(c, y);
    p.slide = u.norm() > 0 ? unit(u) : unit(Vec2(y.row(XI).transpose()));  // at rest: along the spring's pull
  }
  if (rolling_active(c, mode)) {
    p.hold = !(mode & mode_rolling);
    if (!p.hold) {
      const Vec2 w = rolling_rate(y);
      p.roll = w.norm() > 0 ? unit(w) : unit(Vec2(y.row(TH).transpose()));
    }
  }
  return p;
}

/// The generator [[A, B], [0, 0]] of the piece (docs/physics.md 5.6; see the header); the
/// kinetic force and torque follow the normal force, `start` at the piece's start and `slope` per second.
Mat generator(const TangentialConstants& c, const Piece& p, const Vec2& g, const Limits& start, const Limits& slope) {
  Mat m = Mat::Zero();
  m(X, V) = 1;
  for (int d = 0; d < 2; ++d) {
    m(V, forcing + d) = g(d);
    m(ramp + d, forcing + d) = 1;  // t' = 1
  }
  if (p.stick) {
    Eigen::Matrix<Real, 1, rows> f = Eigen::Matrix<Real, 1, rows>::Zero();  // F = -k_t xi - c_t u
    f(V) = -c.c_t;
    f(W) = c.c_t * c.arm;
    f(WJ) = c.c_t * c.arm_j;
    f(XI) = -c.k_t;
    m.block<1, rows>(V, 0) += c.inv_mass * f;
    m.block<1, rows>(W, 0) += (-c.arm * c.inv_inertia) * f;
    m.block<1, rows>(WJ, 0) += (-c.arm_j * c.inv_inertia_j) * f;
    m(XI, V) = 1;
    m(XI, W) = -c.arm;
    m(XI, WJ) = -c.arm_j;
  } else {
    for (int d = 0; d < 2; ++d)
      for (const auto& [column, force] : {std::pair{forcing + d, -start.slide * p.slide(d)},
                                          std::pair{ramp + d, -slope.slide * p.slide(d)}}) {
        m(V, column) += c.inv_mass * force;
        m(W, column) += -c.arm * c.inv_inertia * force;
        m(WJ, column) += -c.arm_j * c.inv_inertia_j * force;
      }
  }
  if (p.hold) {
    Eigen::Matrix<Real, 1, rows> t = Eigen::Matrix<Real, 1, rows>::Zero();  // M = -k_r theta - c_r w_r
    t(TH) = -c.k_r;
    t(W) = -c.c_r;
    t(WJ) = c.c_r;
    m.block<1, rows>(W, 0) += c.inv_inertia * t;
    m.block<1, rows>(WJ, 0) += -c.inv_inertia_j * t;
    m(TH, W) = 1;
    m(TH, WJ) = -1;
  } else {
    for (int d = 0; d < 2; ++d)
      for (const auto& [column, moment] : {std::pair{forcing + d, -start.roll * p.roll(d)},
                                           std::pair{ramp + d, -slope.roll * p.roll(d)}}) {
        m(W, column) += c.inv_inertia * moment;
        m(WJ, column) += -c.inv_inertia_j * moment;
      }
  }
  return m;
}

/// The rate y' = A y + b of a piece's generator at time t since the piece's start.
Planar apply_rate(const Mat& gen, const Planar& y, Real t) {
  return gen.topLeftCorner<rows, rows>() * y + gen.block<rows, 2>(0, forcing) + t * gen.block<rows, 2>(0, ramp);
}

/// Time [s] over which the piece's kinetic directions (slip while sliding, roll while rolling) turn by
/// turn_angle at the state's rate; infinite when they do not turn (motion in one plane).
Real kinetic_turn_time(const TangentialConstants& c, const Piece& p, std::uint8_t mode, const Planar& y,
                       const Planar& rate) {
  constexpr Real turn_angle = 0.2;  // [rad]
  Real t = std::numeric_limits<Real>::infinity();
  const auto limit = [&](const Vec2& v, const Vec2& dv) {
    const Real cross = std::abs(v.x() * dv.y() - v.y() * dv.x()), v2 = v.squaredNorm();
    if (v2 > 0 && cross > 1e-12 * std::sqrt(v2) * dv.norm()) t = std::min(t, turn_angle * v2 / cross);
  };
  if (c.friction && !p.stick && p.slide.norm() > 0) limit(slip(c, y), slip(c, rate));
  if (rolling_active(c, mode) && !p.hold && p.roll.norm() > 0) limit(rolling_rate(y), rolling_rate(rate));
  return t;
}

/// The state after the propagator e from state y at time t since the piece's start (the ramp's value).
Planar apply(const Mat& e, const Planar& y, Real t) {
  return e.topLeftCorner<rows, rows>() * y + e.block<rows, 2>(0, forcing) + t * e.block<rows, 2>(0, ramp);
}

/// The exact flow of one piece: y at time start + t from y at time `start` (times since the piece's
/// start, where its kinetic ramps begin). Without rolling resistance each direction is closed-form: in
/// stick the slip u = v - a_i w_i - a_j w_j and the spring xi are the scalar oscillator of docs/physics.md 5.1
/// (omega^2 = k_t / m_t, 2 beta = c_t / m_t, forcing g), and v, w_i, w_j, x follow from the spring-dashpot
/// force's impulse and its integral, both read off the change of u and xi; in slide the kinetic force
/// is a known ramp, so the motion is a polynomial. With rolling resistance (two coupled channels) it is
/// the exponential of the generator, the last one kept for the sampling's repeated interval.
class PieceFlow {
 public:
  PieceFlow(const TangentialConstants& c, const Piece& p, const Vec2& g, const Limits& lim, const Limits& slope,
            TangentialFlow kind)
      : c_(c), p_(p), g_(g), lim_(lim), slope_(slope) {
    inv_mt_ = c.inv_mass + c.arm * c.arm * c.inv_inertia + c.arm_j * c.arm_j * c.inv_inertia_j;
    closed_ = kind == TangentialFlow::closed_form && c.rolling == RollingKind::none && inv_mt_ > 0;
    if (!closed_) gen_ = generator(c, p, g, lim, slope);
  }

  Planar operator()(const Planar& y, Real start, Real t) const {
    if (!closed_) {
      if (!(t == cached_t_)) {
        cached_ = exponential(t * gen_);
        cached_t_ = t;
      }
      return apply(cached_, y, start);
    }
    Planar out = y;
    const Real t2 = t * t;
    if (p_.stick) {
      const PropagatorCoefficients& k = recent_propagator(std::sqrt(c_.k_t * inv_mt_), 0.5 * c_.c_t * inv_mt_, t);
      for (int d = 0; d < 2; ++d) {
        const Real u0 = y(V, d) - c_.arm * y(W, d) - c_.arm_j * y(WJ, d), xi0 = y(XI, d), g = g_(d);
        const Real d_xi = (k.phi11 - 1) * xi0 + k.phi12 * u0 + k.gamma1 * g;
        const Real d_u = k.phi21 * xi0 + (k.phi22 - 1) * u0 + k.gamma2 * g;
        const Real impulse = (d_u - g * t) / inv_mt_;                  // integral of F over t [N s]
        const Real moment = (d_xi - u0 * t - 0.5 * g * t2) / inv_mt_;  // its integral [N s^2]
        add_response(out, y, d, t, impulse, moment);
        out(XI, d) += d_xi;
      }
    } else {
      for (int d = 0; d < 2; ++d) {
        // F = f0 + f1 s over the flow (s from its start), -mu F_n along the frozen slip direction.
        const Real f1 = -slope_.slide * p_.slide(d), f0 = -lim_.slide * p_.slide(d) + f1 * start;
        add_response(out, y, d, t, f0 * t + 0.5 * f1 * t2, (0.5 * f0 + f1 * t / 6) * t2);
      }
    }
    return out;
  }

 private:
  /// Moves direction d of `out` (a copy of y) under a tangential force of the given impulse and its
  /// integral over t, with the body acceleration g.
  void add_response(Planar& out, const Planar& y, int d, Real t, Real impulse, Real moment) const {
    const Real g = g_(d);
    out(X, d) += y(V, d) * t + c_.inv_mass * moment + 0.5 * g * t * t;
    out(V, d) += c_.inv_mass * impulse + g * t;
    out(W, d) -= c_.arm * c_.inv_inertia * impulse;
    out(WJ, d) -= c_.arm_j * c_.inv_inertia_j * impulse;
  }

  const TangentialConstants& c_;
  Piece p_;
  Vec2 g_;
  Limits lim_, slope_;
  Real inv_mt_ = 0;
  bool closed_ = false;
  Mat gen_;
  mutable Mat cached_;
  mutable Real cached_t_ = -1;
};

/// Which switches have fired in state y (bits: 1 stick->slide, 2 slide->stick, 4 static->roll,
/// 8 roll->static) and the largest switching function, scaled by its limit (> 0: fired).
struct Switching {
  Real value;
  unsigned fired;
};

Switching switching(const TangentialConstants& c, const Limits& lim, const Piece& p, std::uint8_t mode,
                    const Planar& y) {
  Switching s{-1, 0};
  auto add = [&](Real value, unsigned bit) {
    s.value = std::max(s.value, value);
    if (value > 0) s.fired |= bit;
  };
  const Vec2 u = slip(c, y), w = rolling_rate(y);
  if (p.stick) {
    // The law's conditions (the spring alone, the dashpot alone), and the static force itself: it
    // never exceeds mu_s F_n (contact_law.h caps the sum; a flow slides instead).
    const Vec2 xi = y.row(XI).transpose();
    add(c.k_t * xi.norm() / lim.stick - 1, 1);
    add(c.c_t * u.norm() / lim.stick - 1, 1);
    add(Vec2(c.k_t * xi + c.c_t * u).norm() / lim.stick - 1, 1);
  } else if (c.friction && lim.slide > 0 && p.slide.norm() > 0) {
    add(-u.dot(p.slide), 2);  // the slip turned towards the kinetic force [m/s]
  }
  if (p.hold) {
    add(c.k_r * Vec2(y.row(TH).transpose()).norm() / lim.hold - 1, 4);
    add(c.c_r * w.norm() / lim.hold - 1, 4);
  } else if (rolling_active(c, mode) && lim.roll > 0 && p.roll.norm() > 0) {
    add(-w.dot(p.roll), 8);  // [rad/s]
  }
  return s;
}

/// Fastest rate of the piece [1/s], for the sampling that brackets the switches.
Real fastest_rate(const TangentialConstants& c, const Piece& p) {
  Real rate = 0;
  if (p.stick) {
    const Real inv_mt = c.inv_mass + c.arm * c.arm * c.inv_inertia + c.arm_j * c.arm_j * c.inv_inertia_j;
    rate += std::sqrt(c.k_t * inv_mt) + c.c_t * inv_mt;
  }
  const Real inv_ir = c.inv_inertia + c.inv_inertia_j;
  if (p.hold) rate += std::sqrt(c.k_r * inv_ir) + c.c_r * inv_ir;
  return rate;
}

Real energy(const TangentialConstants& c, const Planar& y, const Vec2& g) {
  Real e = 0;
  for (int d = 0; d < 2; ++d) {
    if (c.inv_mass > 0) e += (0.5 * y(V, d) * y(V, d) - g(d) * y(X, d)) / c.inv_mass;
    if (c.inv_inertia > 0) e += 0.5 * y(W, d) * y(W, d) / c.inv_inertia;
    if (c.inv_inertia_j > 0) e += 0.5 * y(WJ, d) * y(WJ, d) / c.inv_inertia_j;
    if (c.friction) e += 0.5 * c.k_t * y(XI, d) * y(XI, d);
    if (c.rolling != RollingKind::none) e += 0.5 * c.k_r * y(TH, d) * y(TH, d);
  }
  return e;
}

/// Makes the springs of the kinetic channels consistent with their kinetic responses under the limits
/// `lim` (the law's reset: the spring holds minus the response over its stiffness).
void reset_kinetic_springs(const TangentialConstants& c, const Piece& p, std::uint8_t mode, const Limits& lim,
                           Planar& y) {
  if (c.friction && !p.stick) y.row(XI) = (lim.slide / c.k_t * p.slide).transpose();
  if (rolling_active(c, mode) && !p.hold) y.row(TH) = (lim.roll / c.k_r * p.roll).transpose();
}

}  // namespace

Real advance_tangential(const TangentialConstants& c, const Vec3& n, Real load, Real load_rate, const Vec3& g_t,
                        Real tau, TangentialState& s, ContactHistory& history, TangentialEvents* events,
                        TangentialFlow kind) {
  // Tangent basis: e1 from a fixed axis, so an in-plane (2-D) wall keeps direction 2 along z.
  const Vec3 axis = std::abs(n.x()) < 0.9 ? Vec3(Vec3::UnitX()) : Vec3(Vec3::UnitY());
  const Vec3 e1 = (axis - axis.dot(n) * n).normalized(), e2 = n.cross(e1);
  const Real spin_n = s.spin.dot(n), spin_j_n = s.spin_j.dot(n);
  Planar y;
  y.col(0) << 0, s.velocity.dot(e1), s.spin.dot(e2), s.spin_j.dot(e2), history.tangential_spring.dot(e1),
      history.rolling_spring.dot(e2);
  y.col(1) << 0, s.velocity.dot(e2), -s.spin.dot(e1), -s.spin_j.dot(e1), history.tangential_spring.dot(e2),
      -history.rolling_spring.dot(e1);
  const Vec2 g(g_t.dot(e1), g_t.dot(e2));
  const Real f_start = std::max(load, Real{0});
  const auto lim_at = [&](Real t) { return limits(c, std::max(Real{0}, f_start + load_rate * t)); };
  const Limits slope = limits(c, load_rate);
  std::uint8_t mode = history.mode;
  const Real e_start = energy(c, y, g);
  settle(c, lim_at(0), y, mode);
  const Real e_settled = energy(c, y, g);

  auto to_state = [&](const Planar& z, TangentialState& out) {
    out.velocity = z(V, 0) * e1 + z(V, 1) * e2;
    out.spin = spin_n * n - z(W, 1) * e1 + z(W, 0) * e2;
    out.spin_j = spin_j_n * n - z(WJ, 1) * e1 + z(WJ, 0) * e2;
    out.displacement = s.displacement + z(X, 0) * e1 + z(X, 1) * e2;
  };

  constexpr int max_events = 16, max_turns = 8;
  Real done = 0;
  int switches = 0, turns = 0;
  Piece p = piece_of(c, y, mode);
  while (done < tau) {
    Real left = tau - done;
    const Limits lim = lim_at(done);
    // Out of plane a kinetic direction turns as the slip (roll) changes: cut the piece where it would
    // have turned by turn_angle and take the direction predicted at the piece's middle (second order).
    bool turning = false;
    const bool kinetic = (c.friction && !p.stick) || (rolling_active(c, mode) && !p.hold);
    if (kinetic && turns < max_turns) {
      const Planar rate = apply_rate(generator(c, p, g, lim, slope), y, 0);
      const Real t = kinetic_turn_time(c, p, mode, y, rate);
      if (t < left) {
        left = t;
        turning = true;
        // Where the middle's direction has reversed, the slip (roll) stops inside: a switch the sampling
        // finds, so the start's direction stays.
        const Piece middle = piece_of(c, Planar(y + (0.5 * t) * rate), mode);
        if (middle.slide.dot(p.slide) > 0) p.slide = middle.slide;
        if (middle.roll.dot(p.roll) > 0) p.roll = middle.roll;
      }
    }
    const PieceFlow flow(c, p, g, lim, slope, kind);
    const bool can_switch = switches < max_events;
    // Bracket the first switch by sampling at a quarter of the fastest period (a linear piece needs
    // one interval: its switching functions are monotone).
    const Real rate = fastest_rate(c, p);
    const int samples = can_switch ? std::clamp(static_cast<int>(std::ceil(left * rate / (0.25 * pi))), 1, 4096) : 1;
    const Real dt = left / samples;
    Planar before = y;
    int fired_at = -1;
    Real value_before = can_switch ? switching(c, lim, p, mode, y).value : 0, value_after = 0;
    for (int k = 0; k < samples; ++k) {
      const Planar after = k + 1 == samples ? flow(y, 0, left) : flow(before, k * dt, dt);
      const Real at = done + (k + 1 == samples ? left : (k + 1) * dt);
      if (can_switch && (value_after = switching(c, lim_at(at), p, mode, after).value) > 0) {
        fired_at = k;
        break;
      }
      before = after;
      value_before = value_after;
    }
    if (fired_at < 0) {
      y = before;
      reset_kinetic_springs(c, p, mode, lim_at(done + left), y);
      if (!turning) break;
      done += left;
      ++turns;
      p = piece_of(c, y, mode);
      continue;
    }
    // Narrow [lo, hi] (times from `before`) down to round-off; the switch is at hi, where it has fired.
    // Regula falsi with the Illinois rule (an end kept twice has its value halved, so both ends close
    // in), bisecting where the interpolation fails or has moved the same end three times running: the
    // switching function is smooth between kinks, so this takes a few evaluations where bisection
    // takes fifty.
    const Real start = fired_at * dt;
    Real lo = 0, hi = fired_at + 1 == samples ? left - start : dt;
    // A start already past a threshold by less than settle()'s tolerance switches at once.
    if (value_before > 0) hi = 0;
    Real f_lo = std::min(value_before, Real{0}), f_hi = value_after;
    const Real resolution = 4 * std::numeric_limits<Real>::epsilon() * tau;
    const auto value_at = [&](Real t) { return switching(c, lim_at(done + start + t), p, mode, flow(before, start, t)).value; };
    // An end exactly on a threshold (a slide at zero slip, or a hit of the root itself) is the switch
    // when the function has risen by the time round-off resolves: probed once, so that no bisection
    // walks down to it from the whole interval.
    const auto probe_past_lo = [&] {
      if (!(f_lo == 0 && lo + resolution < hi)) return;
      const Real f = value_at(lo + resolution);
      if (f > 0) hi = lo + resolution, f_hi = f;
      else lo += resolution, f_lo = f;
    };
    probe_past_lo();
    // Done when the bracket reaches the time's round-off or the fired end's value that of the function.
    const Real small = 1e-13 * std::max(-f_lo, f_hi);
    int kept = 0, run = 0;  // kept: +1 hi moved last, -1 lo moved last; run: times in a row
    for (int it = 0; it < 200 && hi - lo > resolution && f_hi > small; ++it) {
      // At least half the resolution from either end: an interpolation onto an end whose value is
      // round-off then closes the bracket at once.
      Real mid = std::clamp(lo + (hi - lo) * (-f_lo / (f_hi - f_lo)), lo + 0.5 * resolution, hi - 0.5 * resolution);
      if (!(mid > lo && mid < hi) || run >= 3) mid = lo + 0.5 * (hi - lo);
      if (!(mid > lo && mid < hi)) break;
      const Real f = value_at(mid);
      const int side = f > 0 ? 1 : -1;
      run = side == kept ? run + 1 : 1;
      if (side == 1) {
        hi = mid, f_hi = f;
        if (kept == 1) f_lo *= 0.5;
      } else {
        lo = mid, f_lo = f;
        if (kept == -1) f_hi *= 0.5;
      }
      kept = side;
      probe_past_lo();
    }
    y = flow(before, start, hi);
    const unsigned fired = switching(c, lim_at(done + start + hi), p, mode, y).fired;
    done += start + hi;
    const Limits now = lim_at(done);
    reset_kinetic_springs(c, p, mode, now, y);
    if (fired & 1) mode |= mode_sliding;
    if (fired & 2) mode &= static_cast<std::uint8_t>(~mode_sliding);
    if (fired & 4) mode |= mode_rolling;
    if (fired & 8) {
      mode &= static_cast<std::uint8_t>(~mode_rolling);
      y.row(TH).setZero();  // the hold starts unloaded (contact_law.h rolling_spring)
    }
    if (c.rolling != RollingKind::none && !rolling_active(c, mode)) {
      mode |= mode_rolling;
      y.row(TH).setZero();
    }
    ++switches;
    p = piece_of(c, y, mode);
    reset_kinetic_springs(c, p, mode, now, y);  // a new slide or roll starts consistent with its response
    if (events && events->count < TangentialEvents::capacity) {
      TangentialEvent& e = events->event[events->count++];
      e.time = done;
      e.mode = mode;
      to_state(y, e.state);
    }
  }
  const Real e_end = energy(c, y, g);
  TangentialState out;
  to_state(y, out);
  s = out;
  history.tangential_spring = y(XI, 0) * e1 + y(XI, 1) * e2;
  history.rolling_spring = -y(TH, 1) * e1 + y(TH, 0) * e2;
  history.mode = mode;
  return (e_start - e_settled) + (e_settled - e_end);
}

}  // namespace dem
