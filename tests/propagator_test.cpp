// Tests of engine/propagator.h: the closed-form propagator of delta'' + 2 beta delta' + omega0^2 delta = a
// (docs/physics.md 5.1) and the force-zero / overlap-zero times (docs/physics.md 5.3).
// Oracles: a long-double RK4 of the ODE written here (many small substeps), the head-on collision
// values of docs/physics.md 8.2, the closed forms of engine/damping.h (independent code, docs/physics.md 2.2),
// and exact identities: semigroup Phi(h1) Phi(h2) = Phi(h1 + h2), energy conservation and exact
// composition without damping (docs/physics.md 8.6), the ODE's own derivative across branch switches.
#include "engine/propagator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "engine/damping.h"

namespace dem {
namespace {

using Long = long double;
constexpr Real kInfinity = std::numeric_limits<Real>::infinity();
// The docs/physics.md 8.2 pair: m* = 0.5 kg, k = 1e5 N/m.
const Real kOmega0 = std::sqrt(1e5 / 0.5);  // [1/s]

// ---------------------------------------------------------------------------------------------
// Reference: classical RK4 in long double (64-bit mantissa, so round-off stays far below the
// truncation error). Substeps are 5e-4 of the fastest time scale still alive: 1/|lambda_fast|
// during the first 60 fast time constants, then 5e-4/|lambda_slow| capped at 2/|lambda_fast|
// (RK4 damps the dead fast mode there, |R(-2)| = 1/3). Truncation: ~ (5e-4)^4/120 per unit of
// dimensionless time, < 2e-13 relative after 100 contact times.

class StepRule {
 public:
  StepRule(Long omega0, Long beta) {
    const Long d = (omega0 - beta) * (omega0 + beta);
    if (d > 0) {
      fast_ = slow_ = omega0;
    } else {
      const Long s = std::sqrt(-d);
      fast_ = beta + s;
      slow_ = fast_ > 0 ? omega0 * omega0 / fast_ : 0;
    }
  }
  Long substep(Long t) const {
    constexpr Long c = 5e-4L;
    if (fast_ == 0) return std::numeric_limits<Long>::infinity();
    if (t < 60 / fast_) return c / fast_;
    const Long slow_step = slow_ > 0 ? c / slow_ : std::numeric_limits<Long>::infinity();
    return std::min(slow_step, 2 / fast_);
  }
  Long fast() const { return fast_; }
  Long slow() const { return slow_; }

 private:
  Long fast_ = 0;
  Long slow_ = 0;
};

struct Oscillator {
  Long omega0, beta;
};

// One RK4 step of (delta, rate) under constant forcing a.
void rk4_step(const Oscillator& o, Long a, Long& delta, Long& rate, Long h) {
  const Long w2 = o.omega0 * o.omega0;
  const Long b2 = 2 * o.beta;
  auto acc = [&](Long d, Long r) { return a - b2 * r - w2 * d; };
  const Long k1d = rate, k1r = acc(delta, rate);
  const Long k2d = rate + h / 2 * k1r, k2r = acc(delta + h / 2 * k1d, rate + h / 2 * k1r);
  const Long k3d = rate + h / 2 * k2r, k3r = acc(delta + h / 2 * k2d, rate + h / 2 * k2r);
  const Long k4d = rate + h * k3r, k4r = acc(delta + h * k3d, rate + h * k3r);
  delta += h / 6 * (k1d + 2 * k2d + 2 * k3d + k4d);
  rate += h / 6 * (k1r + 2 * k2r + 2 * k3r + k4r);
}

// Coefficients at each (increasing) time of `times` from the three unit columns
// (delta0, rate0, a) = (1, 0, 0), (0, 1, 0), (0, 0, 1), integrated together.
std::vector<PropagatorCoefficients> rk4_coefficients(Real omega0, Real beta, const std::vector<Real>& times) {
  const Oscillator o{omega0, beta};
  const StepRule rule(omega0, beta);
  Long delta[3] = {1, 0, 0};
  Long rate[3] = {0, 1, 0};
  Long t = 0;
  std::vector<PropagatorCoefficients> out;
  for (const Real target : times) {
    while (t < target) {
      const Long h = std::min(rule.substep(t), static_cast<Long>(target) - t);
      for (int j = 0; j < 3; ++j) rk4_step(o, j == 2 ? 1 : 0, delta[j], rate[j], h);
      t += h;
    }
    out.push_back({static_cast<Real>(delta[0]), static_cast<Real>(delta[1]), static_cast<Real>(rate[0]),
                   static_cast<Real>(rate[1]), static_cast<Real>(delta[2]), static_cast<Real>(rate[2])});
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Error measure. Coefficients are made dimensionless with W = max(omega0, beta, 1/h) and grouped by
// the state they act on: {phi11, W phi12} (delta row), {phi21/W, phi22} (rate row) and
// {W^2 gamma1, W gamma2} (forcing). Each entry's error is relative to its own size, floored at 1% of
// its group's largest entry, so a coefficient passing through zero is judged against the state it
// contributes to; everywhere else this is the plain relative error. The forcing pair can vanish
// together (undamped, omega0 h = 2 pi n); its envelope is O(1) in these units (W^2 gamma1 = 1/2 for
// small h, 1 - cos undamped, beta h/2 over-damped), so its floor is at least 1e-2.

Real group_error(Real got1, Real ref1, Real got2, Real ref2, Real envelope = 0) {
  const Real floor = 1e-2 * std::max({std::fabs(ref1), std::fabs(ref2), envelope});
  auto one = [&](Real got, Real ref) {
    const Real scale = std::max(std::fabs(ref), floor);
    return scale > 0 ? std::fabs(got - ref) / scale : std::fabs(got - ref);
  };
  return std::max(one(got1, ref1), one(got2, ref2));
}

Real coefficient_error(const PropagatorCoefficients& got, const PropagatorCoefficients& ref, Real omega0, Real beta,
                       Real h) {
  const Real w = std::max({omega0, beta, 1 / h});
  return std::max({group_error(got.phi11, ref.phi11, w * got.phi12, w * ref.phi12),
                   group_error(got.phi21 / w, ref.phi21 / w, got.phi22, ref.phi22),
                   group_error(w * w * got.gamma1, w * w * ref.gamma1, w * got.gamma2, w * ref.gamma2, 1)});
}

bool all_finite(const PropagatorCoefficients& p) {
  for (const Real v : {p.phi11, p.phi12, p.phi21, p.phi22, p.gamma1, p.gamma2}) {
    if (!std::isfinite(v)) return false;
  }
  return true;
}

// Product map: first h1 (p1), then h2 (p2).
PropagatorCoefficients compose(const PropagatorCoefficients& p1, const PropagatorCoefficients& p2) {
  return {p2.phi11 * p1.phi11 + p2.phi12 * p1.phi21, p2.phi11 * p1.phi12 + p2.phi12 * p1.phi22,
          p2.phi21 * p1.phi11 + p2.phi22 * p1.phi21, p2.phi21 * p1.phi12 + p2.phi22 * p1.phi22,
          p2.phi11 * p1.gamma1 + p2.phi12 * p1.gamma2 + p2.gamma1,
          p2.phi21 * p1.gamma1 + p2.phi22 * p1.gamma2 + p2.gamma2};
}

struct Regime {
  const char* name;
  Real omega0, beta;
  Real time_unit;  // the "contact time" the step list is measured in [s]
};

std::vector<Regime> regimes() {
  const Real tc = pi / kOmega0;
  auto z = [&](const char* name, Real zeta) { return Regime{name, kOmega0, zeta * kOmega0, tc}; };
  return {z("zeta=0", 0),
          z("zeta=0.1", 0.1),
          z("zeta=0.5", 0.5),
          z("zeta=1-1e-4", 1 - 1e-4),
          z("zeta=1-1e-8", 1 - 1e-8),
          z("zeta=1", 1),
          z("zeta=1+1e-8", 1 + 1e-8),
          z("zeta=1+1e-4", 1 + 1e-4),
          z("zeta=2", 2),
          z("zeta=1e3", 1e3),
          Regime{"omega0=1e-12,beta=0", 1e-12, 0, 1},
          Regime{"omega0=1e-12,beta=0.3", 1e-12, 0.3, 1}};
}

const std::vector<Real>& step_factors() {
  static const std::vector<Real> f = {1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.03, 0.1, 0.3, 1, 3, 10, 30, 100};
  return f;
}

TEST(Propagator, MatchesRk4InAllRegimes) {
  Real worst = 0;
  std::string worst_where;
  for (const Regime& r : regimes()) {
    std::vector<Real> times;
    for (const Real f : step_factors()) times.push_back(f * r.time_unit);
    const std::vector<PropagatorCoefficients> ref = rk4_coefficients(r.omega0, r.beta, times);
    Real regime_worst = 0;
    for (std::size_t i = 0; i < times.size(); ++i) {
      const PropagatorCoefficients got = propagator(r.omega0, r.beta, times[i]);
      const Real err = coefficient_error(got, ref[i], r.omega0, r.beta, times[i]);
      EXPECT_LE(err, 1e-10) << r.name << " h = " << step_factors()[i] << " t_c";
      regime_worst = std::max(regime_worst, err);
      if (err > worst) {
        worst = err;
        worst_where = std::string(r.name) + " h/t_c = " + std::to_string(step_factors()[i]);
      }
    }
    std::printf("  %-24s worst error vs RK4 %.2e\n", r.name, regime_worst);
  }
  std::printf("  overall worst %.2e at %s\n", worst, worst_where.c_str());
}

// Textbook closed form in long double, one formula per regime (cos/sin, 1/h, cosh/sinh): no
// branch switch near zeta = 1 to hide a jump, and 11 more bits than the engine's double.
// gamma1 = (1 - phi11)/omega0^2 is used only where omega0 h >= 0.09 (cancellation <= 1e-16 there).
PropagatorCoefficients textbook(Real omega0, Real beta, Real h) {
  const Long w = omega0;
  const Long b = beta;
  const Long t = h;
  const Long d = (w - b) * (w + b);
  Long c = 1;
  Long s = t;
  if (d > 0) {
    const Long wd = std::sqrt(d);
    c = std::cos(wd * t);
    s = std::sin(wd * t) / wd;
  } else if (d < 0) {
    const Long sd = std::sqrt(-d);
    c = std::cosh(sd * t);
    s = std::sinh(sd * t) / sd;
  }
  const Long e = std::exp(-b * t);
  const Long phi11 = e * (c + b * s);
  return {static_cast<Real>(phi11),         static_cast<Real>(e * s),
          static_cast<Real>(-w * w * e * s), static_cast<Real>(e * (c - b * s)),
          static_cast<Real>((1 - phi11) / (w * w)), static_cast<Real>(e * s)};
}

TEST(Propagator, ContinuousAcrossCriticalDamping) {
  // At zeta = 1 - 1e-8, 1 and 1 + 1e-8 the coefficients match the long-double textbook forms of
  // their own regime (cos/sin, critical, cosh/sinh), so the engine's single path has no jump at
  // zeta = 1. Where the physical change (~1e-8 relative times powers of omega0 h) is below 1e-12,
  // the three also agree with each other to 1e-12.
  const Real eps = 1e-8;
  Real worst = 0;
  Real worst_spread = 0;
  for (const Real f : step_factors()) {
    const Real h = f * pi / kOmega0;
    const PropagatorCoefficients mid = propagator(kOmega0, kOmega0, h);
    for (const Real zeta : {1 - eps, 1.0, 1 + eps}) {
      const Real beta = zeta * kOmega0;
      const PropagatorCoefficients got = propagator(kOmega0, beta, h);
      if (kOmega0 * h >= 0.09) {
        const Real err = coefficient_error(got, textbook(kOmega0, beta, h), kOmega0, beta, h);
        EXPECT_LE(err, 1e-13) << "zeta = 1 + " << (zeta - 1) << " h = " << f << " t_c";
        worst = std::max(worst, err);
      }
      if (kOmega0 * h < 1e-4) {
        const Real spread = coefficient_error(got, mid, kOmega0, beta, h);
        EXPECT_LE(spread, 1e-12) << "zeta = 1 + " << (zeta - 1) << " h = " << f << " t_c";
        worst_spread = std::max(worst_spread, spread);
      }
    }
  }
  std::printf("  zeta = 1 -+ 1e-8: worst error vs long-double textbook forms %.2e, spread at small h %.2e\n", worst,
              worst_spread);
}

TEST(Propagator, ContinuousAcrossBranchSwitches) {
  // Central differences across each switch point h_s match h_s-derivatives from the ODE itself
  // (Phi' = A Phi, Gamma' = A Gamma + e2), so a jump of more than round-off between branches fails.
  struct Switch {
    const char* name;
    Real beta, h;
  };
  const Real w = kOmega0;
  auto z_switch = [&](Real zeta) {  // |omega0^2 - beta^2| h^2 = 1e-3
    return std::sqrt(1e-3 / std::fabs((1 - zeta) * (1 + zeta))) / w;
  };
  const std::vector<Switch> switches = {
      {"z=+1e-3, zeta=0.5", 0.5 * w, z_switch(0.5)},
      {"z=+1e-3, zeta=0.999", 0.999 * w, z_switch(0.999)},
      {"z=-1e-3, zeta=2", 2 * w, z_switch(2)},
      {"z=-1e-3, zeta=1.001", 1.001 * w, z_switch(1.001)},
      {"rho h=1, zeta=0", 0, 1 / w},
      {"rho h=1, zeta=1", w, 1 / (3 * w)},
      {"rho h=1, zeta=5", 5 * w, 1 / (11 * w)},
      {"rho h=1, zeta=1e3", 1e3 * w, 1 / (2001 * w)},
  };
  Real worst = 0;
  for (const Switch& s : switches) {
    const Real dh = 1e-7 * s.h;
    const PropagatorCoefficients lo = propagator(w, s.beta, s.h - dh);
    const PropagatorCoefficients hi = propagator(w, s.beta, s.h + dh);
    const PropagatorCoefficients c = propagator(w, s.beta, s.h);
    const Real w2 = w * w;
    const Real b2 = 2 * s.beta;
    // Predicted hi from lo by the derivative at h_s times 2 dh.
    const PropagatorCoefficients predicted = {
        lo.phi11 + 2 * dh * c.phi21,
        lo.phi12 + 2 * dh * c.phi22,
        lo.phi21 + 2 * dh * (-w2 * c.phi11 - b2 * c.phi21),
        lo.phi22 + 2 * dh * (-w2 * c.phi12 - b2 * c.phi22),
        lo.gamma1 + 2 * dh * c.gamma2,
        lo.gamma2 + 2 * dh * (1 - w2 * c.gamma1 - b2 * c.gamma2)};
    const Real err = coefficient_error(hi, predicted, w, s.beta, s.h);
    EXPECT_LE(err, 1e-13) << s.name;
    worst = std::max(worst, err);
  }
  std::printf("  worst jump across branch switches: %.2e\n", worst);
}

TEST(Propagator, FiniteAtExtremes) {
  for (const Real zeta : {0.0, 0.5, 1.0, 2.0, 1e3, 1e6}) {
    for (const Real wh : {0.0, 1e-300, 1e-12, 1.0, 1e6, 1e12}) {
      const PropagatorCoefficients p = propagator(kOmega0, zeta * kOmega0, wh / kOmega0);
      EXPECT_TRUE(all_finite(p)) << "zeta = " << zeta << " omega0 h = " << wh;
    }
  }
  // Free flight exactly: omega0 = 0, with and without drag.
  const PropagatorCoefficients free = propagator(0, 0, 2.0);
  EXPECT_EQ(free.phi11, 1.0);
  EXPECT_EQ(free.phi12, 2.0);
  EXPECT_EQ(free.phi21, 0.0);
  EXPECT_EQ(free.phi22, 1.0);
  EXPECT_DOUBLE_EQ(free.gamma1, 2.0);
  EXPECT_DOUBLE_EQ(free.gamma2, 2.0);
  const Real beta = 0.7;
  const Real h = 3.0;
  const PropagatorCoefficients drag = propagator(0, beta, h);
  const Real decay = std::exp(-2 * beta * h);
  EXPECT_NEAR(drag.phi11, 1.0, 1e-15);
  EXPECT_NEAR(drag.phi12, (1 - decay) / (2 * beta), 1e-15);
  EXPECT_EQ(drag.phi21, 0.0);
  EXPECT_NEAR(drag.phi22, decay, 1e-15);
  EXPECT_NEAR(drag.gamma1, (h - (1 - decay) / (2 * beta)) / (2 * beta), 1e-14);
  EXPECT_NEAR(drag.gamma2, (1 - decay) / (2 * beta), 1e-15);
  // Zero step is the identity.
  const PropagatorCoefficients id = propagator(kOmega0, 0.3 * kOmega0, 0);
  EXPECT_EQ(id.phi11, 1.0);
  EXPECT_EQ(id.phi12, 0.0);
  EXPECT_EQ(id.phi22, 1.0);
  EXPECT_EQ(id.gamma1, 0.0);
}

TEST(Propagator, SemigroupWithDamping) {
  Real worst = 0;
  for (const Real zeta : {0.0, 0.1, 0.7, 1.0, 1 + 1e-6, 1.5, 3.0, 1e3}) {
    const Real beta = zeta * kOmega0;
    for (const Real f1 : {1e-4, 0.07, 0.4, 1.3, 9.0}) {
      for (const Real f2 : {3e-5, 0.05, 0.6, 2.2}) {
        const Real h1 = f1 / kOmega0;
        const Real h2 = f2 / kOmega0;
        const PropagatorCoefficients product =
            compose(propagator(kOmega0, beta, h1), propagator(kOmega0, beta, h2));
        const PropagatorCoefficients direct = propagator(kOmega0, beta, h1 + h2);
        const Real err = coefficient_error(product, direct, kOmega0, beta, h1 + h2);
        EXPECT_LE(err, 1e-12) << "zeta = " << zeta << " omega0 h1 = " << f1 << " omega0 h2 = " << f2;
        worst = std::max(worst, err);
      }
    }
  }
  std::printf("  worst semigroup defect: %.2e\n", worst);
}

TEST(Propagator, UndampedEnergyConservedAndStepsCompose) {
  Real worst_energy = 0;
  Real worst_compose = 0;
  for (const Real wh : {0.3, 1.5, 10.0}) {
    const Real h = wh / kOmega0;
    const PropagatorCoefficients p = propagator(kOmega0, 0, h);
    auto energy = [&](Real d, Real r) { return 0.5 * r * r + 0.5 * kOmega0 * kOmega0 * d * d; };
    Real d = 0;
    Real r = 1;
    const Real e0 = energy(d, r);
    Real drift = 0;
    for (int i = 0; i < 100000; ++i) {
      const Real nd = p.phi11 * d + p.phi12 * r;
      r = p.phi21 * d + p.phi22 * r;
      d = nd;
      drift = std::max(drift, std::fabs(energy(d, r) / e0 - 1));
    }
    EXPECT_LE(drift, 2e-11) << "omega0 h = " << wh;  // round-off: 1e5 steps x ~1 ulp of det Phi
    worst_energy = std::max(worst_energy, drift);

    // N steps of h against one step of N h (N h exact in floating point).
    const int n = wh > 5 ? 128 : 1024;
    Real d1 = 1e-3;
    Real r1 = 0.4;
    for (int i = 0; i < n; ++i) {
      const Real nd = p.phi11 * d1 + p.phi12 * r1;
      r1 = p.phi21 * d1 + p.phi22 * r1;
      d1 = nd;
    }
    const PropagatorCoefficients big = propagator(kOmega0, 0, n * h);
    const Real d2 = big.phi11 * 1e-3 + big.phi12 * 0.4;
    const Real r2 = big.phi21 * 1e-3 + big.phi22 * 0.4;
    const Real norm = std::hypot(kOmega0 * 1e-3, 0.4);
    const Real err = std::hypot(kOmega0 * (d1 - d2), r1 - r2) / norm;
    EXPECT_LE(err, 1e-12) << "omega0 h = " << wh << " N = " << n;
    worst_compose = std::max(worst_compose, err);
  }
  std::printf("  worst energy drift over 1e5 steps %.2e; N steps vs one step %.2e\n", worst_energy, worst_compose);
}

// ---------------------------------------------------------------------------------------------
// docs/physics.md 8.2: m* = 0.5, k = 1e5, zeta = 0.1, start at delta = 0 with rate = v_imp.

TEST(ContactTimes, HeadOnOracle) {
  const Real beta = 0.1 * kOmega0;
  for (const Real v : {1.0, 2.5}) {
    const Real t_force = force_zero_time(kOmega0, beta, 0, v, 0);
    const PropagatorCoefficients pf = propagator(kOmega0, beta, t_force);
    EXPECT_NEAR(t_force, 6.6100e-3, 0.5e-7);
    EXPECT_NEAR(-pf.phi22, 0.74408, 0.5e-5);  // e = -rate(t_c)/v_imp, delta0 = 0
    // Independent closed forms of engine/damping.h.
    EXPECT_NEAR(t_force * kOmega0, dimensionless_contact_time(0.1, Separation::force_zero), 1e-12);
    EXPECT_NEAR(-pf.phi22, restitution_from_damping_ratio(0.1, Separation::force_zero), 1e-12);
    // Force is zero there.
    EXPECT_NEAR(kOmega0 * kOmega0 * pf.phi12 + 2 * beta * pf.phi22, 0, 1e-12 * 2 * beta);

    const Real t_overlap = overlap_zero_time(kOmega0, beta, 0, v, 0);
    const PropagatorCoefficients po = propagator(kOmega0, beta, t_overlap);
    EXPECT_NEAR(t_overlap, 7.0602e-3, 0.5e-7);
    EXPECT_NEAR(-po.phi22, 0.72925, 0.5e-5);
    EXPECT_NEAR(t_overlap * kOmega0, dimensionless_contact_time(0.1, Separation::overlap), 1e-12);
    EXPECT_NEAR(-po.phi22, restitution_from_damping_ratio(0.1, Separation::overlap), 1e-12);

    // delta_max at delta' = 0: tan(omega_d t) = omega_d/beta.
    const Real wd = kOmega0 * std::sqrt(1 - 0.01);
    const Real t_max = std::atan(wd / beta) / wd;
    EXPECT_NEAR(t_max, 3.305e-3, 0.5e-6);
    EXPECT_NEAR(propagator(kOmega0, beta, t_max).phi12, 1.9288e-3, 0.5e-7);
  }
  // Undamped: e = 1, t_c = pi/omega0 = 7.0248e-3 s.
  EXPECT_NEAR(force_zero_time(kOmega0, 0, 0, 1, 0), 7.0248e-3, 0.5e-7);
  EXPECT_NEAR(overlap_zero_time(kOmega0, 0, 0, 1, 0), pi / kOmega0, 1e-17);
  EXPECT_NEAR(-propagator(kOmega0, 0, pi / kOmega0).phi22, 1.0, 1e-15);
}

TEST(ContactTimes, ForceZeroClosedFormMatchesDampingTable) {
  // a = 0 from delta = 0 across the three regimes and next to zeta = 1; damping.h switches to the
  // exact critical value inside 1 -+ 1e-6, so compare there against t = 2/omega0 to O(1e-8).
  for (const Real zeta : {0.0, 0.03427, 0.25528, 0.49724, 0.7, 0.999, 1.001, 1.24319, 3.0, 30.0, 1e3}) {
    const Real t = force_zero_time(kOmega0, zeta * kOmega0, 0, 1, 0);
    EXPECT_NEAR(t * kOmega0, dimensionless_contact_time(zeta, Separation::force_zero),
                1e-12 * dimensionless_contact_time(zeta, Separation::force_zero))
        << "zeta = " << zeta;
  }
  for (const Real zeta : {1 - 1e-8, 1.0, 1 + 1e-8}) {
    EXPECT_NEAR(force_zero_time(kOmega0, zeta * kOmega0, 0, 1, 0) * kOmega0, 2.0, 3e-8) << "zeta = " << zeta;
  }
  // Free flight with drag never loses its (dashpot) force; undamped free flight has none.
  EXPECT_EQ(force_zero_time(0, 3.0, 0, 1, 0), kInfinity);
  EXPECT_EQ(force_zero_time(kOmega0, 0, 0, 0, 0), kInfinity);
  // Over-damped overlap never returns to zero without forcing.
  EXPECT_EQ(overlap_zero_time(kOmega0, 2 * kOmega0, 0, 1, 0), kInfinity);
  // Free flight: delta = 1 - t.
  EXPECT_NEAR(overlap_zero_time(1e-12, 0, 1, -1, 0), 1.0, 1e-12);
  EXPECT_NEAR(overlap_zero_time(0, 0, 1, -1, 0), 1.0, 1e-15);
}

// First t > 0 at which q = w2 delta + 2 beta delta' (force) or q = delta changes sign, by RK4 with a
// bisection on the length of the last step; infinity if none before `horizon`.
Long rk4_root(Real omega0, Real beta, Real delta0, Real rate0, Real a, bool force, Long horizon) {
  const Oscillator o{omega0, beta};
  const StepRule rule(omega0, beta);
  auto q = [&](Long d, Long r) {
    return force ? static_cast<Long>(omega0) * omega0 * d + 2 * static_cast<Long>(beta) * r : d;
  };
  Long d = delta0;
  Long r = rate0;
  Long t = 0;
  Long sign = q(d, r) > 0 ? 1 : (q(d, r) < 0 ? -1 : 0);
  while (t < horizon) {
    const Long h = rule.substep(t);
    Long nd = d;
    Long nr = r;
    rk4_step(o, a, nd, nr, h);
    const Long qn = q(nd, nr);
    if (sign == 0) {
      sign = qn > 0 ? 1 : -1;
    } else if (sign * qn <= 0) {
      Long lo = 0;
      Long hi = h;
      for (int i = 0; i < 90; ++i) {
        const Long mid = 0.5L * (lo + hi);
        Long md = d;
        Long mr = r;
        rk4_step(o, a, md, mr, mid);
        if (sign * q(md, mr) > 0) {
          lo = mid;
        } else {
          hi = mid;
        }
      }
      return t + 0.5L * (lo + hi);
    }
    d = nd;
    r = nr;
    t += h;
  }
  return std::numeric_limits<Long>::infinity();
}

TEST(ContactTimes, RootsMatchRk4WithForcingAndMidContactStarts) {
  struct Start {
    Real delta0, rate0, a;  // [m], [m/s], [m/s^2]
  };
  const std::vector<Start> starts = {
      {0, 1, 100},         // onset, body force pressing in (ball landing on a floor)
      {0, 1, -300},        // onset, pulled apart
      {1e-3, -1, 100},     // mid-contact, unloading
      {2e-3, 0.5, 0},      // mid-contact, no forcing (closed form)
      {1e-3, 0.3, -200},   // mid-contact, loading, pulled apart
      {1e-3, -2, 0},       // force already negative at the start
      {-1e-4, 1.5, 50},    // just before onset
  };
  Real worst_force = 0;
  Real worst_overlap = 0;
  int finite_roots = 0;
  int no_roots = 0;
  for (const Real zeta : {0.0, 0.1, 0.5, 0.9, 1.0, 1 + 1e-6, 1.2, 3.0, 30.0, 1e3}) {
    const Real beta = zeta * kOmega0;
    const StepRule rule(kOmega0, beta);
    const Long no_root_horizon = 40 / rule.slow() + 40 / kOmega0;
    for (const Start& s : starts) {
      for (const bool force : {true, false}) {
        const Real t = force ? force_zero_time(kOmega0, beta, s.delta0, s.rate0, s.a)
                             : overlap_zero_time(kOmega0, beta, s.delta0, s.rate0, s.a);
        const Long horizon = std::isfinite(t) ? 1.5L * t : no_root_horizon;
        // At zeta = 1e3 confirming "no root" would need RK4 through the slow tail (~1e8 steps).
        if (!std::isfinite(t) && zeta >= 1e3) continue;
        const Long ref = rk4_root(kOmega0, beta, s.delta0, s.rate0, s.a, force, horizon);
        const std::string where = std::string(force ? "force" : "overlap") + " zeta=" + std::to_string(zeta) +
                                  " start=(" + std::to_string(s.delta0) + "," + std::to_string(s.rate0) + "," +
                                  std::to_string(s.a) + ")";
        if (!std::isfinite(t)) {
          EXPECT_FALSE(std::isfinite(static_cast<Real>(ref))) << where << " rk4 root " << static_cast<Real>(ref);
          ++no_roots;
          continue;
        }
        ++finite_roots;
        const Real err = static_cast<Real>(std::fabs(t - ref) / ref);
        EXPECT_LE(err, 1e-9) << where << " t = " << t << " rk4 " << static_cast<Real>(ref);
        Real& worst = force ? worst_force : worst_overlap;
        worst = std::max(worst, err);
      }
    }
  }
  std::printf("  %d finite roots, %d confirmed absent; worst relative error vs RK4: force %.2e, overlap %.2e\n",
              finite_roots, no_roots, worst_force, worst_overlap);
}

TEST(PropagatorTable, CachesPerClassAndLevel) {
  PropagatorTable table;
  const Real dt = 1e-4;
  const PropagatorCoefficients& a = table.get(7, -2, kOmega0, 0.2 * kOmega0, dt);
  const PropagatorCoefficients expected = propagator(kOmega0, 0.2 * kOmega0, dt / 4);
  EXPECT_EQ(a.phi11, expected.phi11);
  EXPECT_EQ(a.phi12, expected.phi12);
  EXPECT_EQ(a.phi21, expected.phi21);
  EXPECT_EQ(a.phi22, expected.phi22);
  EXPECT_EQ(a.gamma1, expected.gamma1);
  EXPECT_EQ(a.gamma2, expected.gamma2);
  const PropagatorCoefficients& b = table.get(7, 1, kOmega0, 0.2 * kOmega0, dt);
  EXPECT_EQ(b.phi12, propagator(kOmega0, 0.2 * kOmega0, 2 * dt).phi12);
  EXPECT_EQ(&table.get(7, -2, kOmega0, 0.2 * kOmega0, dt), &a);  // cached, stable reference
  EXPECT_EQ(table.find(7, -2), &a);
  EXPECT_EQ(table.find(7, 0), nullptr);
  EXPECT_EQ(table.find(8, -2), nullptr);
  EXPECT_EQ(table.size(), 2u);
  table.clear();
  EXPECT_EQ(table.size(), 0u);
}

}  // namespace
}  // namespace dem
