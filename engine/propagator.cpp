// Closed-form propagator of delta'' + 2 beta delta' + omega0^2 delta = a (docs/physics.md 5.1) and the
// force-zero and overlap-zero times along its trajectory (docs/physics.md 5.3).
//
// Notation: d = omega0^2 - beta^2 = omega_d^2 = -s^2, z = d h^2, E = e^(-beta h); over-damped
// eigenvalues lambda+- = -beta +- s, written with the positive rates slow = -lambda+ =
// omega0^2/(beta + s) (no cancellation) and fast = -lambda- = beta + s.
// Accuracy: every coefficient to a few ulps of its own size or of the state it multiplies; the
// worst cancellation left is a factor ~30 in the over-damped branch right at |z| = 1e-3.
#include "engine/propagator.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>

#include "engine/checks.h"

namespace dem {
namespace {

constexpr Real infinity = std::numeric_limits<Real>::infinity();
constexpr Real epsilon = std::numeric_limits<Real>::epsilon();

// |z| below which C and S come from their Taylor series. There the switch between cos/sin and
// cosh/sinh (and the square root of d, which changes sign at zeta = 1) is avoided altogether.
constexpr Real series_z_limit = 1e-3;

// Taylor series of C = cos(sqrt z) and S/h = sin(sqrt z)/sqrt z (cosh/sinh for z < 0) in w = -z,
// four terms each (w^0..w^3): for |z| < 1e-3 the first omitted terms are z^4/8! <= 2.5e-17 and
// z^4/9! <= 2.8e-18, below half an ulp of the leading 1, so the sums are correctly rounded to
// within the round-off of the Horner evaluation.
Real series_c(Real w) { return 1 + w / 2 * (1 + w / 12 * (1 + w / 30 * (1 + w / 56))); }
Real series_s_over_h(Real w) { return 1 + w / 6 * (1 + w / 20 * (1 + w / 42 * (1 + w / 72))); }

// gamma1 = h^2 sum_{n>=2} v_n, the Taylor series of the forced response (delta0 = rate0 = 0,
// a = 1): v_2 = 1/2, v_3 = -beta h/3, v_4 = (4 beta^2 - omega0^2) h^2/24, ... from the recursion
// (n+2)(n+1) v_{n+2} = -2 (beta h)(n+1) v_{n+1} - (omega0 h)^2 v_n. Used for rho h < 1 with
// rho = omega0 + 2 beta >= max|lambda|: the n-th term is at most 2 (n-1) (rho h)^(n-2) / n! of
// the leading one, so 19 terms (n = 2..20) leave <= 40/21! = 7.8e-19 relative. Replaces
// (1 - phi11)/omega0^2, which cancels catastrophically when omega0^2 h^2 is small.
constexpr int gamma1_series_last = 20;
Real gamma1_series(Real omega0, Real beta, Real h) {
  const Real bh = beta * h;
  const Real wh2 = (omega0 * h) * (omega0 * h);
  Real previous = 0;  // v_1
  Real current = 0.5;  // v_2
  Real sum = current;
  for (int n = 1; n + 2 <= gamma1_series_last; ++n) {
    const Real next = -(2 * bh * (n + 1) * current + wh2 * previous) / ((n + 2) * (n + 1));
    sum += next;
    previous = current;
    current = next;
  }
  return h * h * sum;
}

// (1 - e^(-mu h))/mu, equal to h at mu = 0.
Real relaxation_integral(Real mu, Real h) {
  const Real x = mu * h;
  return x > 0 ? -std::expm1(-x) / mu : h;
}

}  // namespace

PropagatorCoefficients propagator(Real omega0, Real beta, Real h) {
  DEM_ASSERT(omega0 >= 0 && beta >= 0 && h >= 0);
  const Real w2 = omega0 * omega0;
  const Real d = (omega0 - beta) * (omega0 + beta);  // factored: accurate next to zeta = 1
  const Real z = d * h * h;
  const bool small_forcing_series = (omega0 + 2 * beta) * h < 1;
  PropagatorCoefficients p{};

  if (z >= -series_z_limit) {
    // Under-damped, critical and near-critical: Phi = E [C I + S (A + beta I)].
    Real c = 0;
    Real s = 0;
    if (z > series_z_limit) {
      const Real wd = std::sqrt(d);
      c = std::cos(wd * h);
      s = std::sin(wd * h) / wd;
    } else {
      c = series_c(-z);
      s = h * series_s_over_h(-z);
    }
    const Real e = std::exp(-beta * h);
    const Real es = e * s;
    p.phi11 = e * (c + beta * s);
    p.phi12 = es;
    p.phi21 = -w2 * es;
    p.phi22 = e * (c - beta * s);
    p.gamma2 = es;
    // Outside the series omega0 h > 0.3 here (z >= -1e-3 and rho h >= 1), so 1 - phi11 >= 0.04 at
    // zeta = 1 and the subtraction loses at most ~1.5 digits; where 1 - phi11 itself nears zero
    // (undamped, omega0 h = 2 pi n) the error stays ~eps/omega0^2 absolute.
    p.gamma1 = small_forcing_series ? gamma1_series(omega0, beta, h) : (1 - p.phi11) / w2;
    return p;
  }

  // Over-damped: E cosh = (e+ + e-)/2, E sinh = (e+ - e-)/2 with e+- = e^(lambda+- h), written as
  // e+ (1 +- x)/2, x = e^(-2 s h) <= 1, so no exponential exceeds 1 (zeta = 1e3 at any h).
  const Real s = std::sqrt(-d);
  const Real fast = beta + s;
  const Real slow = w2 / fast;
  const Real e_slow = std::exp(-slow * h);
  const Real x = std::exp(-2 * s * h);
  const Real one_minus_x = -std::expm1(-2 * s * h);
  p.phi12 = e_slow * one_minus_x / (2 * s);
  p.phi11 = e_slow * ((1 + x) * s + beta * one_minus_x) / (2 * s);  // both terms >= 0
  // phi22 = e+ (x fast - slow)/(2 s) = e+ (2 s - (1 - x) fast)/(2 s): the first form is exact-ish
  // for strong damping, the second next to zeta = 1; take the one with the smaller terms.
  const Real far_form = x * fast - slow;
  const Real near_form = 2 * s - one_minus_x * fast;
  const bool use_far = std::max(x * fast, slow) <= std::max(2 * s, one_minus_x * fast);
  p.phi22 = e_slow * (use_far ? far_form : near_form) / (2 * s);
  p.phi21 = -w2 * p.phi12;
  p.gamma2 = p.phi12;
  // gamma1 = (1 - phi11)/omega0^2 = ((1 - e^(-slow h))/slow - phi12)/fast: no division by omega0,
  // and outside the series (fast h >= 1/3) the difference cancels by at most a factor ~12.
  p.gamma1 = small_forcing_series ? gamma1_series(omega0, beta, h)
                                  : (relaxation_integral(slow, h) - p.phi12) / fast;
  return p;
}

namespace {

// Eigen-structure of the oscillator used by the root finders.
struct Modes {
  Real d = 0;     // omega0^2 - beta^2 [1/s^2]
  Real wd = 0;    // omega_d [1/s] when d > 0
  Real s = 0;     // sqrt(-d) [1/s] when d < 0
  Real slow = 0;  // -lambda+ = omega0^2/(beta + s) [1/s] when d <= 0
};

Modes modes_of(Real omega0, Real beta) {
  Modes m;
  m.d = (omega0 - beta) * (omega0 + beta);
  if (m.d > 0) {
    m.wd = std::sqrt(m.d);
  } else {
    m.s = std::sqrt(-m.d);
    const Real fast = beta + m.s;
    m.slow = fast > 0 ? omega0 * omega0 / fast : 0;
  }
  return m;
}

// First t > 0 with w(t) = 0 for a solution w of the homogeneous equation, w(0) = w0, w'(0) = w1;
// +infinity if none. w = E (P C + Q S) with P = w0, Q = w1 + beta w0.
// Under-damped: P cos + (Q/omega_d) sin = 0, solved with atan so that the root tends smoothly
// to -P/Q (the critical root) as omega_d -> 0.
// Critical and over-damped: w = (A2 e^(lambda+ t) + B2 e^(lambda- t))/(2 s) with
// A2 = w1 + (beta + s) w0 passed in by the caller in a cancellation-free form (it is the
// slow-mode amplitude, tiny for strong damping); the root is t = log1p(-2 s w0/A2)/(2 s),
// and -w0/A2 at s = 0.
Real first_zero_homogeneous(const Modes& m, Real beta, Real w0, Real w1, Real slow_amplitude) {
  if (m.d > 0) {
    const Real p = w0;
    const Real q = w1 + beta * w0;
    if (p == 0) return q == 0 ? infinity : pi / m.wd;
    if (q == 0) return 0.5 * pi / m.wd;
    const Real r = -p / q;
    const Real x = m.wd * std::fabs(r);
    if (r < 0) return (pi - std::atan(x)) / m.wd;
    if (x == 0) return r;
    if (std::isinf(x)) return 0.5 * pi / m.wd;
    return r * (std::atan(x) / x);
  }
  if (w0 == 0 || slow_amplitude == 0) return infinity;  // A2 + B2 = 0, or a pure fast mode
  const Real r = -w0 / slow_amplitude;
  if (!(r > 0)) return infinity;
  const Real y = 2 * m.s * r;
  if (y == 0) return r;
  if (std::isinf(y)) return (std::log(2 * m.s) + std::log(std::fabs(w0)) - std::log(std::fabs(slow_amplitude))) / (2 * m.s);
  return r * (std::log1p(y) / y);
}

enum class Quantity { overlap, force };

// The function whose first root is sought, u = delta or u = omega0^2 delta + 2 beta delta', on
// the exact trajectory.
struct Trajectory {
  Real omega0, beta, delta0, rate0, a;
  Quantity quantity;

  // u(t) and u'(t).
  void evaluate(Real t, Real& u, Real& du) const {
    const PropagatorCoefficients p = propagator(omega0, beta, t);
    const Real delta = p.phi11 * delta0 + p.phi12 * rate0 + p.gamma1 * a;
    const Real rate = p.phi21 * delta0 + p.phi22 * rate0 + p.gamma2 * a;
    if (quantity == Quantity::overlap) {
      u = delta;
      du = rate;
      return;
    }
    const Real w2 = omega0 * omega0;
    u = w2 * delta + 2 * beta * rate;
    du = w2 * rate + 2 * beta * (a - 2 * beta * rate - w2 * delta);
  }
};

// Safeguarded Newton (Numerical Recipes' rtsafe) for the single root of the monotone u on
// [lo, hi], oriented so that sign * u(lo) >= 0 >= sign * u(hi).
Real solve_bracketed(const Trajectory& tr, Real sign, Real lo, Real hi) {
  Real u = 0;
  Real du = 0;
  tr.evaluate(hi, u, du);
  if (u == 0) return hi;
  Real t = 0.5 * (lo + hi);
  Real dx_old = hi - lo;
  Real dx = dx_old;
  for (int iteration = 0; iteration < 400; ++iteration) {
    tr.evaluate(t, u, du);
    const Real f = sign * u;
    const Real df = sign * du;
    if (f == 0) return t;
    if (f > 0) {
      lo = t;
    } else {
      hi = t;
    }
    const Real newton = df != 0 ? t - f / df : lo;
    Real next = 0;
    if (!(newton > lo && newton < hi) || std::fabs(2 * f) > std::fabs(dx_old * df)) {
      dx_old = dx;
      dx = 0.5 * (hi - lo);
      next = lo + dx;
    } else {
      dx_old = dx;
      dx = f / df;
      next = newton;
    }
    if (std::fabs(dx) <= 2 * epsilon * next || next == t || hi - lo <= 2 * epsilon * hi) return next;
    t = next;
  }
  return t;
}

// First root of u for a != 0. u' solves the homogeneous equation, so u is monotone between
// consecutive zeros of u': t1 (first_zero_homogeneous) and, under-damped, t1 + pi/omega_d. Each
// later extremum of u - u(infinity) is e^(-beta pi/omega_d) times the one two before, so if u keeps
// its sign up to the second extremum it keeps it for ever. Critical and over-damped: after t1,
// u tends monotonically to its limit, of the sign of a for both quantities; a doubling search
// brackets the root when that sign is opposite.
Real first_root(const Trajectory& tr, Real sign, const Modes& m, Real t1) {
  Real lo = 0;
  Real u = 0;
  Real du = 0;
  const Real ends[2] = {t1, m.d > 0 ? t1 + pi / m.wd : infinity};
  for (const Real end : ends) {
    if (!(end < infinity)) break;
    tr.evaluate(end, u, du);
    if (sign * u <= 0) return solve_bracketed(tr, sign, lo, end);
    lo = end;
  }
  if (m.d > 0 || sign * tr.a >= 0) return infinity;
  const Real rate_scale = tr.omega0 + 2 * tr.beta;
  Real hi = lo > 0 ? 2 * lo : (rate_scale > 0 ? 1 / rate_scale : 1);
  for (int doubling = 0; doubling < 2200 && hi < infinity; ++doubling) {
    tr.evaluate(hi, u, du);
    if (sign * u <= 0) return solve_bracketed(tr, sign, lo, hi);
    lo = hi;
    hi *= 2;
  }
  return infinity;
}

// Sign of u just after t = 0 from u and its first two derivatives there; 0 if all vanish.
Real initial_sign(Real u0, Real u1, Real u2) {
  for (const Real v : {u0, u1, u2}) {
    if (v > 0) return 1;
    if (v < 0) return -1;
  }
  return 0;
}

// delta^(k)(0) for k = 0..4 from delta'' = a - 2 beta delta' - omega0^2 delta.
struct InitialDerivatives {
  Real v[5];
};

InitialDerivatives initial_derivatives(Real omega0, Real beta, Real delta0, Real rate0, Real a) {
  const Real w2 = omega0 * omega0;
  InitialDerivatives r{};
  r.v[0] = delta0;
  r.v[1] = rate0;
  r.v[2] = a - 2 * beta * rate0 - w2 * delta0;
  r.v[3] = -2 * beta * r.v[2] - w2 * r.v[1];
  r.v[4] = -2 * beta * r.v[3] - w2 * r.v[2];
  return r;
}

}  // namespace

// For k >= 1, delta^(k) solves the homogeneous equation and its slow-mode amplitude is
// A2 = delta^(k+1)(0) + (beta + s) delta^(k)(0) = (-slow)^(k-1) K, K = a - omega0^2 delta0 - slow rate0
// (the sum -2 beta + (beta + s) = -slow is done analytically).
Real force_zero_time(Real omega0, Real beta, Real delta0, Real rate0, Real a) {
  DEM_ASSERT(omega0 >= 0 && beta >= 0);
  const Modes m = modes_of(omega0, beta);
  const InitialDerivatives dv = initial_derivatives(omega0, beta, delta0, rate0, a);
  const Real force0 = omega0 * omega0 * delta0 + 2 * beta * rate0;  // = a - delta''
  const Real sign = initial_sign(force0, -dv.v[3], -dv.v[4]);
  if (sign == 0) return infinity;
  const Real k = a - omega0 * omega0 * delta0 - m.slow * rate0;
  if (a == 0) return first_zero_homogeneous(m, beta, dv.v[2], dv.v[3], -m.slow * k);  // force = -delta''
  const Real t1 = first_zero_homogeneous(m, beta, dv.v[3], dv.v[4], m.slow * m.slow * k);
  return first_root(Trajectory{omega0, beta, delta0, rate0, a, Quantity::force}, sign, m, t1);
}

Real overlap_zero_time(Real omega0, Real beta, Real delta0, Real rate0, Real a) {
  DEM_ASSERT(omega0 >= 0 && beta >= 0);
  const Modes m = modes_of(omega0, beta);
  const InitialDerivatives dv = initial_derivatives(omega0, beta, delta0, rate0, a);
  const Real sign = initial_sign(delta0, rate0, dv.v[2]);
  if (sign == 0) return infinity;
  if (a == 0) return first_zero_homogeneous(m, beta, delta0, rate0, rate0 + (beta + m.s) * delta0);
  const Real k = a - omega0 * omega0 * delta0 - m.slow * rate0;
  const Real t1 = first_zero_homogeneous(m, beta, dv.v[1], dv.v[2], k);
  return first_root(Trajectory{omega0, beta, delta0, rate0, a, Quantity::overlap}, sign, m, t1);
}

const PropagatorCoefficients& recent_propagator(Real omega0, Real beta, Real h) {
  struct Entry {
    Real omega0 = -1, beta = -1, h = -1;
    PropagatorCoefficients coefficients{};
  };
  constexpr int size = 4;
  thread_local Entry entries[size];
  thread_local int next = 0;
  for (Entry& e : entries)
    if (e.omega0 == omega0 && e.beta == beta && e.h == h) return e.coefficients;
  Entry& e = entries[next];
  next = (next + 1) % size;
  e = {omega0, beta, h, propagator(omega0, beta, h)};
  return e.coefficients;
}

const PropagatorCoefficients& PropagatorTable::get(std::uint32_t cls, int level, Real omega0, Real beta,
                                                   Real dt_base) {
  const Real h = std::ldexp(dt_base, level);
  const auto [it, inserted] = entries_.try_emplace({cls, level}, Entry{omega0, beta, h, {}});
  if (inserted) {
    it->second.coefficients = propagator(omega0, beta, h);
  } else {
    DEM_ASSERT(it->second.omega0 == omega0 && it->second.beta == beta && it->second.h == h);
  }
  return it->second.coefficients;
}

const PropagatorCoefficients* PropagatorTable::find(std::uint32_t cls, int level) const {
  const auto it = entries_.find({cls, level});
  return it == entries_.end() ? nullptr : &it->second.coefficients;
}

}  // namespace dem
