#include "engine/exact_friction.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

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
    const Real spring = c.k_t * Vec2(y.row(XI).transpose()).norm();
    const Real u = slip(c, y).norm();
    if (!(mode & mode_sliding)) {
      if (!(lim.stick > 0) || spring > tol * lim.stick || c.c_t * u > tol * lim.stick) mode |= mode_sliding;
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

/// The generator [[A, B], [0, 0]] of the piece (PHYSICS.md 1.3, 1.4 in planar form; see the header); the
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
    add(c.k_t * Vec2(y.row(XI).transpose()).norm() / lim.stick - 1, 1);
    add(c.c_t * u.norm() / lim.stick - 1, 1);
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
                        Real tau, TangentialState& s, ContactHistory& history, TangentialEvents* events) {
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
    if (turns < max_turns) {
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
    const Mat gen = generator(c, p, g, lim, slope);
    const bool can_switch = switches < max_events;
    // Bracket the first switch by sampling at a quarter of the fastest period (a linear piece needs
    // one interval: its switching functions are monotone).
    const Real rate = fastest_rate(c, p);
    const int samples = can_switch ? std::clamp(static_cast<int>(std::ceil(left * rate / (0.25 * pi))), 1, 4096) : 1;
    const Real dt = left / samples;
    const Mat step = samples > 1 ? exponential(dt * gen) : Mat();
    Planar before = y;
    int fired_at = -1;
    for (int k = 0; k < samples; ++k) {
      const Planar after = k + 1 == samples ? apply(exponential(left * gen), y, 0) : apply(step, before, k * dt);
      const Real at = done + (k + 1 == samples ? left : (k + 1) * dt);
      if (can_switch && switching(c, lim_at(at), p, mode, after).value > 0) {
        fired_at = k;
        break;
      }
      before = after;
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
    // Bisect [lo, hi] (times from `before`) down to round-off; the switch is at hi, where it has fired.
    const Real start = fired_at * dt;
    Real lo = 0, hi = fired_at + 1 == samples ? left - start : dt;
    for (int it = 0; it < 200; ++it) {
      const Real mid = lo + 0.5 * (hi - lo);
      if (!(mid > lo && mid < hi)) break;
      if (switching(c, lim_at(done + start + mid), p, mode, apply(exponential(mid * gen), before, start)).value > 0)
        hi = mid;
      else
        lo = mid;
    }
    y = apply(exponential(hi * gen), before, start);
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
