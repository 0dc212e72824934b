// Contact physics through the World (fixed control, velocity Verlet) against the analytic oracles of
// docs/physics.md section 8: free fall, head-on restitution and contact time in both separation
// conventions, sliding to rolling, static hold on an incline, rolling-resistance stopping distance,
// energy and momentum conservation, Verlet convergence order, 2-D discs, and walls.
// Every expected value is derived here from docs/physics.md formulas; none is copied from engine output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

// ---------------------------------------------------------------------------------------------
// 6.1 Free fall

TEST(ContactPhysics, FreeFallIsExactAtAnyStep) {
  const Vec3 g(0.3, -0.2, -9.81);
  const Vec3 x0(0.1, -2.0, 50.0), v0(1.5, 2.0, 3.0);
  for (Real dt : {1e-4, 1e-3, 1.7e-2, 0.1, 0.37}) {
    SCOPED_TRACE(dt);
    WorldConfig c = base_config(dt);
    c.model.gravity = g;
    c.particles.push_back(particle(x0, v0, 0.1, 2.0));
    World world(c);
    const long n = 2000;
    for (long chunk = 0; chunk < 4; ++chunk) {
      advance(world, n / 4);
      const Real t = dt * static_cast<Real>((chunk + 1) * (n / 4));
      const Vec3 x = x0 + v0 * t + 0.5 * g * t * t;
      const Vec3 v = v0 + g * t;
      // Verlet is exact for a constant force: only round-off, growing at most ~ n eps |x|.
      const Real x_scale = x0.norm() + v0.norm() * t + 0.5 * g.norm() * t * t;
      const Real v_scale = v0.norm() + g.norm() * t;
      const Real eps = std::numeric_limits<Real>::epsilon();
      EXPECT_LE((world.state().position[0] - x).norm(), 4.0 * n * eps * x_scale);
      EXPECT_LE((world.state().velocity[0] - v).norm(), 4.0 * n * eps * v_scale);
    }
    // A first-order (Euler-like) integrator would be off by g t h / 2: make sure that is far above
    // the tolerance, so this test can fail.
    const Real t = dt * n;
    EXPECT_GT(0.5 * g.norm() * t * dt, 1e3 * 4.0 * n * std::numeric_limits<Real>::epsilon() *
                                           (x0.norm() + v0.norm() * t + 0.5 * g.norm() * t * t));
  }
}

// ---------------------------------------------------------------------------------------------
// 6.2 Head-on collision of two equal spheres (scene: head_on in contact_scenes.h)

// Error constants of velocity Verlet on one collision, chosen from analysis and checked against the
// measured maxima over 8 onset phases (ratios in brackets measured at omega0 h = 0.08, 0.02, 0.005):
//  - damped, restitution: the dashpot force jumps by c v at onset, an O(h) impulse error of at
//    most ~ zeta omega0 h: C = 0.3 [max 0.23];
//  - damped, omega0 t_c: onset is exact (free flight), the end is known to +-h/2 from sampling plus
//    O(h) from the dashpot using the half-step velocity: C = 2.5 [max 2.15];
//  - undamped, |e - 1|: the trapezoidal impulse error at a force kink crossed at phase phi of a step is
//    phi (1 - phi) / 2 <= 1/8 of (omega0 h)^2, once at onset and once at separation: C = 0.2 [max 0.11].
constexpr Real kRestitutionC = 0.3;
constexpr Real kContactTimeC = 2.5;
constexpr Real kUndampedC = 0.2;

TEST(ContactPhysics, HeadOnCollisionMatchesSection62Numbers) {
  // m1 = m2 = 1 (m* = 0.5), k = 1e5, zeta = 0.1: omega0 = 447.21 1/s. omega0 h = 1e-4.
  const Real k = 1e5, m_star = 0.5, omega0 = std::sqrt(k / m_star);
  EXPECT_NEAR(omega0, 447.21, 0.005);
  const Real w0h = 1e-4, dt = w0h / omega0;
  const Damping zeta{DampingKind::damping_ratio, 0.1};
  const Real tol_e = kRestitutionC * w0h + 5e-6;    // + half a unit of the table's last digit
  const Real tol_t = kContactTimeC * dt + 5e-8;
  {
    const Collision fz = head_on(k, zeta, Separation::force_zero, dt);
    EXPECT_NEAR(fz.restitution, 0.74408, tol_e);
    EXPECT_NEAR(fz.contact_time, 6.6100e-3, tol_t);
    // delta_max = 1.9288e-3 v_imp at t = 3.305e-3 s after onset (v_imp = 1 m/s here).
    EXPECT_NEAR(fz.max_overlap, 1.9288e-3, 1.9288e-3 * kRestitutionC * w0h + 5e-8);
    EXPECT_NEAR(fz.time_of_max, 3.305e-3, kContactTimeC * dt + 5e-7);
  }
  {
    const Collision ov = head_on(k, zeta, Separation::overlap, dt);
    EXPECT_NEAR(ov.restitution, 0.72925, tol_e);
    EXPECT_NEAR(ov.contact_time, 7.0602e-3, tol_t);
    EXPECT_NEAR(ov.max_overlap, 1.9288e-3, 1.9288e-3 * kRestitutionC * w0h + 5e-8);
    EXPECT_NEAR(ov.time_of_max, 3.305e-3, kContactTimeC * dt + 5e-7);
  }
  {
    // Undamped: e = 1, t_c = pi / omega0 = 7.0248e-3 s, delta_max = v_imp / omega0 at t_c / 2.
    const Collision un = head_on(k, Damping{}, Separation::force_zero, dt);
    EXPECT_NEAR(un.restitution, 1.0, kUndampedC * w0h * w0h + 1e-12);
    EXPECT_NEAR(un.contact_time, 7.0248e-3, 0.5 * dt + 5e-8);
    EXPECT_NEAR(un.max_overlap, 1.0 / omega0, (w0h * w0h + 1e-12) / omega0);
  }
}

TEST(ContactPhysics, HeadOnRestitutionAndContactTimeMatchBothConventions) {
  // Restitution given as DampingKind::restitution; the oracle for e is the input itself, the oracle
  // for t_c the closed forms of docs/physics.md 2.2 (re-derived above, independent of engine/damping.cpp).
  const Real k = 1e5, m_star = 0.5, omega0 = std::sqrt(k / m_star);
  Real worst_e = 0, worst_t = 0;
  for (Separation sep : {Separation::force_zero, Separation::overlap}) {
    for (Real e : {0.1, 0.2, 0.3, 0.5, 0.7, 0.8, 0.9, 0.95}) {
      const ContactOracle o = oracle_from_ratio(oracle_ratio_from_restitution(e, sep), sep);
      for (Real w0h : {0.02, 0.005}) {
        for (Real phase : {0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875}) {
          SCOPED_TRACE(::testing::Message() << "separation " << static_cast<int>(sep) << " e " << e
                                            << " omega0 h " << w0h << " phase " << phase);
          const Collision col = head_on(k, Damping{DampingKind::restitution, e}, sep, w0h / omega0, 1.0, phase);
          const Real err_e = std::abs(col.restitution - e) / w0h;
          const Real err_t = std::abs(col.contact_time * omega0 - o.time) / w0h;
          EXPECT_LE(err_e, kRestitutionC);
          EXPECT_LE(err_t, kContactTimeC);
          worst_e = std::max(worst_e, err_e);
          worst_t = std::max(worst_t, err_t);
        }
      }
    }
  }
  RecordProperty("max_restitution_error_over_omega0_h", sci(worst_e));
  RecordProperty("max_contact_time_error_over_omega0_h", sci(worst_t));
}

TEST(ContactPhysics, UndampedHeadOnRestitutionErrorIsSecondOrder) {
  // docs/physics.md 8.6: with Verlet |e - 1| <= C (omega0 h)^2.
  const Real k = 1e5, omega0 = std::sqrt(k / 0.5);
  Real worst = 0;
  for (Separation sep : {Separation::force_zero, Separation::overlap}) {
    for (Real w0h : {0.08, 0.02, 0.005}) {
      for (Real phase : {0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875}) {
        SCOPED_TRACE(::testing::Message() << "omega0 h " << w0h << " phase " << phase);
        const Collision col = head_on(k, Damping{}, sep, w0h / omega0, 1.0, phase);
        const Real err = std::abs(col.restitution - 1) / (w0h * w0h);
        EXPECT_LE(err, kUndampedC);
        EXPECT_NEAR(col.contact_time * omega0, pi, 0.5 * w0h + kUndampedC * w0h * w0h);
        worst = std::max(worst, err);
      }
    }
  }
  RecordProperty("max_restitution_error_over_omega0_h_squared", sci(worst));
}

// ---------------------------------------------------------------------------------------------
// 6.3 Sliding to rolling on a flat wall

struct SlideResult {
  Real t_roll;         // slip zero [s]
  Real v_roll;         // mean speed while rolling [m/s]
  Real distance;       // travelled until t_roll [m]
  Real energy_lost;    // fraction of the initial kinetic energy
};

struct SlideOracle {
  Real t_roll, v_roll, distance, energy_lost;
};

// Sliding from v0 with no spin, friction mu, lever arm a = R - delta0/2 (the engine's rule,
// docs/physics.md 1.2): slip decelerates at mu g (1 + a^2 / (kappa R^2)); with a = R this is
// docs/physics.md 8.3's t = kappa v0 / ((1 + kappa) mu g), v = v0 / (1 + kappa), distance v0 t - mu g t^2 / 2.
SlideOracle slide_oracle(Real kappa, Real v0, Real mu, Real g, Real radius, Real arm) {
  const Real lambda = 1 + arm * arm / (kappa * radius * radius);
  const Real t = v0 / (mu * g * lambda);
  const Real v = v0 - mu * g * t;
  const Real kinetic_ratio = (v / v0) * (v / v0) * (1 + kappa * radius * radius / (arm * arm));
  return {t, v, v0 * t - 0.5 * mu * g * t * t, 1 - kinetic_ratio};
}

SlideResult slide_to_roll(int dimension, Real v0, Real mu, Real g, Real k, Real radius, Real mass, Real dt) {
  WorldConfig c = base_config(dt, dimension);
  const Vec3 up = dimension == 3 ? Vec3::UnitZ() : Vec3::UnitY();
  c.model.gravity = -g * up;
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = k;
  law.normal_damping = {DampingKind::damping_ratio, 0.3};
  law.tangential_damping = {DampingKind::damping_ratio, 0.05};
  law.sliding_friction = mu;
  law.static_friction = 1.25 * mu;  // the stick oscillation after the transition (<= mu F_n) stays held
  c.walls.push_back(plane(Vec3::Zero(), up));
  const Real delta0 = mass * g / k;  // equilibrium overlap: no normal oscillation at the start
  c.particles.push_back(particle((radius - delta0) * up, Vec3(v0, 0, 0), radius, mass));
  World world(c);
  const Real e0 = world.energies().kinetic + world.energies().rotational;

  // History of time, displacement, speed and slip u = v + omega x (-a n) (a = R - delta/2).
  const Real x0 = world.state().position[0].x();
  std::vector<Real> t_hist, x_hist, v_hist, slip_hist;
  const long steps = static_cast<long>(1.6 * slide_oracle(dimension == 3 ? 0.4 : 0.5, v0, mu, g, radius, radius).t_roll / dt);
  for (long step = 1; step <= steps; ++step) {
    advance(world, 1);
    const State& s = world.state();
    const Real overlap = world.wall_contacts().size() > 0 ? world.wall_contacts().overlap[0] : 0;
    const Vec3 u = s.velocity[0] + s.angular_velocity[0].cross(-(radius - 0.5 * overlap) * up);
    t_hist.push_back(dt * static_cast<Real>(step));
    x_hist.push_back(s.position[0].x() - x0);
    v_hist.push_back(s.velocity[0].x());
    slip_hist.push_back(u.x());
  }
  // Slip decreases linearly while sliding: least-squares line through the samples with slip in
  // [0.02, 0.5] v0, extrapolated to zero.
  Real n = 0, st = 0, ss = 0, stt = 0, sts = 0;
  for (std::size_t i = 0; i < t_hist.size(); ++i) {
    if (slip_hist[i] < 0.02 * v0 || slip_hist[i] > 0.5 * v0) continue;
    n += 1, st += t_hist[i], ss += slip_hist[i], stt += t_hist[i] * t_hist[i], sts += t_hist[i] * slip_hist[i];
  }
  const Real slope = (n * sts - st * ss) / (n * stt - st * st);
  const Real intercept = (ss - slope * st) / n;
  SlideResult r;
  r.t_roll = -intercept / slope;
  // Displacement at t_roll by linear interpolation of the record; mean speed over [1.2, 1.6] t_roll
  // (no horizontal force while rolling on a flat).
  r.distance = x_hist.back();
  Real sum = 0, count = 0;
  for (std::size_t i = 1; i < t_hist.size(); ++i) {
    if (t_hist[i - 1] <= r.t_roll && r.t_roll < t_hist[i]) {
      const Real w = (r.t_roll - t_hist[i - 1]) / (t_hist[i] - t_hist[i - 1]);
      r.distance = (1 - w) * x_hist[i - 1] + w * x_hist[i];
    }
    if (t_hist[i] >= 1.2 * r.t_roll) sum += v_hist[i], count += 1;
  }
  r.v_roll = sum / count;
  r.energy_lost = 1 - (world.energies().kinetic + world.energies().rotational) / e0;
  return r;
}

TEST(ContactPhysics, SlidingSphereRollsAtTwoSeventhsOfFrictionTime) {
  // Stiff contact (delta0 / R = 2e-5) and omega0 h = 0.1, so elastic effects are far below 0.5%.
  const Real v0 = 2, mu = 0.3, g = 9.81, k = 1e7, radius = 0.05, mass = 1;
  const Real dt = 0.1 / std::sqrt(k / mass);
  const SlideResult r = slide_to_roll(3, v0, mu, g, k, radius, mass, dt);
  const SlideOracle o = slide_oracle(0.4, v0, mu, g, radius, radius - 0.5 * mass * g / k);
  // The rigid-contact values of 6.3 (t = 2 v0 / (7 mu g), 5/7 v0, 12 v0^2 / (49 mu g), 2/7 of the
  // energy lost) differ from o by ~delta0 / R; both are checked at 0.5%.
  EXPECT_NEAR(r.t_roll, o.t_roll, 5e-3 * o.t_roll);
  EXPECT_NEAR(r.t_roll, 2 * v0 / (7 * mu * g), 5e-3 * o.t_roll);
  EXPECT_NEAR(r.v_roll, o.v_roll, 5e-3 * o.v_roll);
  EXPECT_NEAR(r.v_roll, 5.0 / 7.0 * v0, 5e-3 * o.v_roll);
  EXPECT_NEAR(r.distance, o.distance, 5e-3 * o.distance);
  EXPECT_NEAR(r.distance, 12 * v0 * v0 / (49 * mu * g), 5e-3 * o.distance);
  EXPECT_NEAR(r.energy_lost, o.energy_lost, 5e-3 * o.energy_lost);
  EXPECT_NEAR(r.energy_lost, 2.0 / 7.0, 5e-3 * o.energy_lost);
  RecordProperty("t_roll_relative_error", sci(r.t_roll / o.t_roll - 1));
}

TEST(ContactPhysics, SlidingDiscRollsAtOneThirdOfFrictionTime) {
  const Real v0 = 2, mu = 0.3, g = 9.81, k = 1e7, radius = 0.05, mass = 1;
  const Real dt = 0.1 / std::sqrt(k / mass);
  const SlideResult r = slide_to_roll(2, v0, mu, g, k, radius, mass, dt);
  const SlideOracle o = slide_oracle(0.5, v0, mu, g, radius, radius - 0.5 * mass * g / k);
  // Rigid values: t = v0 / (3 mu g), v = 2/3 v0, distance 5 v0^2 / (18 mu g), 1/3 of the energy lost.
  EXPECT_NEAR(r.t_roll, o.t_roll, 5e-3 * o.t_roll);
  EXPECT_NEAR(r.t_roll, v0 / (3 * mu * g), 5e-3 * o.t_roll);
  EXPECT_NEAR(r.v_roll, o.v_roll, 5e-3 * o.v_roll);
  EXPECT_NEAR(r.v_roll, 2.0 / 3.0 * v0, 5e-3 * o.v_roll);
  EXPECT_NEAR(r.distance, o.distance, 5e-3 * o.distance);
  EXPECT_NEAR(r.distance, 5 * v0 * v0 / (18 * mu * g), 5e-3 * o.distance);
  EXPECT_NEAR(r.energy_lost, 1.0 / 3.0, 5e-3 * o.energy_lost);
}

// ---------------------------------------------------------------------------------------------
// 6.4 Static hold on an incline, and the accelerations when it does not hold

struct InclineRun {
  Real creep;         // |x(t_end) - x(t_start)| [m]
  Real acceleration;  // down-slope, (v(t_end) - v(t_start)) / (t_end - t_start) [m/s^2]
  Real arm;           // R - delta0 / 2 [m]
};

constexpr Real kInclineRadius = 0.1, kInclineMass = 1, kInclineStiffness = 1e5, kG = 9.81;

InclineRun incline(Real tan_theta, Real mu, Real mu_s, Real mu_r, Real mu_rs, Real t_start, Real t_end) {
  const Real theta = std::atan(tan_theta);
  const Vec3 n(std::sin(theta), 0, std::cos(theta));       // plane normal, tilted about y
  const Vec3 down(std::cos(theta), 0, -std::sin(theta));   // down-slope unit vector
  const Real dt = 2e-4;                                    // omega0 h = 0.063
  WorldConfig c = base_config(dt);
  c.model.gravity = Vec3(0, 0, -kG);
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = kInclineStiffness;
  law.normal_damping = {DampingKind::damping_ratio, 0.5};
  law.tangential_damping = {DampingKind::damping_ratio, 0.5};
  law.sliding_friction = mu;
  law.static_friction = mu_s;
  law.rolling_friction = mu_r;
  law.rolling_static_friction = mu_rs;
  c.walls.push_back(plane(Vec3::Zero(), n));
  const Real delta0 = kInclineMass * kG * std::cos(theta) / kInclineStiffness;
  c.particles.push_back(particle((kInclineRadius - delta0) * n, Vec3::Zero(), kInclineRadius, kInclineMass));
  World world(c);
  advance(world, std::lround(t_start / dt));
  const Vec3 x1 = world.state().position[0];
  const Real v1 = world.state().velocity[0].dot(down);
  advance(world, std::lround((t_end - t_start) / dt));
  EXPECT_EQ(world.wall_contacts().size(), 1u);
  return {(world.state().position[0] - x1).norm(), (world.state().velocity[0].dot(down) - v1) / (t_end - t_start),
          kInclineRadius - 0.5 * delta0};
}

TEST(ContactPhysics, SphereHoldsOnInclineWhenBothStaticLimitsSuffice) {
  // mu_s = 0.5, mu_rs = 0.3 (mu = 0.4 <= mu_s, mu_r = 0.2 <= mu_rs): holds iff tan(theta) <= 0.3.
  // The sphere is put down at rest at its equilibrium overlap, springs unloaded. The static hold of
  // docs/physics.md 2.4 stands for the rigid constraint of docs/physics.md 8.4 (whatever torque keeps
  // omega_r = 0, up to mu_rs R F_n): the spring-dashpot that implements it must not let the loading
  // transient exceed the static limits (once rolling, mu_r < tan(theta) would keep it rolling).
  // Creep measured between t = 1 s (settled: the damped springs decay as exp(-zeta omega t) with
  // zeta omega >= 100 1/s) and t = 11 s.
  for (Real tan_theta : {0.0, 0.1, 0.25, 0.29}) {
    SCOPED_TRACE(tan_theta);
    const InclineRun r = incline(tan_theta, 0.4, 0.5, 0.2, 0.3, 1.0, 11.0);
    EXPECT_LE(r.creep, 1e-9 * kInclineRadius);
    RecordProperty("creep_over_R_at_tan_percent_" + std::to_string(std::lround(100 * tan_theta)),
                   sci(r.creep / kInclineRadius));
  }
}

// Quasi-static version of 6.4 (a tilting table): the plane turns slowly about the y axis through
// the sphere's contact point, from flat, at 0.03 rad/s (the springs' periods are ~20 ms, so loading
// is quasi-static and the sphere co-rotates with the plane: no rolling or slip rate while it holds).
// Motion relative to the plane must start at tan(theta) = mu_s (slide) or mu_rs R / a (roll,
// a = R - delta/2: the friction torque is F a), whichever is smaller.
Real tilt_at_onset(Real mu, Real mu_s, Real mu_r, Real mu_rs) {
  const Real omega = 0.03, dt = 2e-4;
  WorldConfig c = base_config(dt);
  c.model.gravity = Vec3(0, 0, -kG);
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = kInclineStiffness;
  law.normal_damping = {DampingKind::damping_ratio, 0.5};
  law.tangential_damping = {DampingKind::damping_ratio, 0.5};
  law.sliding_friction = mu;
  law.static_friction = mu_s;
  law.rolling_friction = mu_r;
  law.rolling_static_friction = mu_rs;
  WallConfig table = plane(Vec3::Zero(), Vec3::UnitZ());
  table.angular_velocity = Vec3(0, omega, 0);  // n(t) = (sin wt, 0, cos wt)
  c.walls.push_back(table);
  const Real delta0 = kInclineMass * kG / kInclineStiffness;
  // Start co-rotating with the table (at rest relative to it, springs unloaded on the flat).
  const Vec3 x0(0, 0, kInclineRadius - delta0);
  ParticleConfig p = particle(x0, table.angular_velocity.cross(x0), kInclineRadius, kInclineMass);
  p.angular_velocity = table.angular_velocity;
  c.particles.push_back(p);
  World world(c);
  for (long step = 1; step < static_cast<long>(0.6 / omega / dt); ++step) {
    advance(world, 1);
    const Real theta = omega * dt * static_cast<Real>(step);
    // Velocity relative to the plane's material at the particle centre, along the slope.
    const Vec3 x = world.state().position[0];
    const Vec3 relative = world.state().velocity[0] - Vec3(0, omega, 0).cross(x);
    const Vec3 down(std::cos(theta), 0, -std::sin(theta));
    if (relative.dot(down) > 1e-3) return theta;  // rolls or slides: reaches 1 mm/s within ~2 ms
  }
  return -1;
}

TEST(ContactPhysics, SphereOnSlowlyTiltingPlaneStartsToMoveAtStaticLimit) {
  const Real arm = kInclineRadius - 0.5 * kInclineMass * kG / kInclineStiffness;
  {
    // mu_rs = 0.3 < mu_s = 0.5: starts rolling at tan(theta) = 0.3 R / a.
    const Real theta = tilt_at_onset(0.4, 0.5, 0.2, 0.3);
    EXPECT_NEAR(std::tan(theta), 0.3 * kInclineRadius / arm, 5e-3 * 0.3);
    RecordProperty("rolling_onset_tan", sci(std::tan(theta)));
  }
  {
    // mu_s = 0.2 < mu_rs = 0.3: starts sliding at tan(theta) = 0.2.
    const Real theta = tilt_at_onset(0.15, 0.2, 0.2, 0.3);
    EXPECT_NEAR(std::tan(theta), 0.2, 5e-3 * 0.2);
    RecordProperty("sliding_onset_tan", sci(std::tan(theta)));
  }
}

TEST(ContactPhysics, SphereRollsDownWhenRollingStaticLimitIsExceeded) {
  // tan(theta) > mu_rs = 0.3 (friction holds, mu_s = 0.5): rolls, with kinetic mu_r = 0.2 < tan(theta),
  // at g (sin - mu_r cos R/a) / (1 + kappa R^2 / a^2) (6.5 with the engine's lever arm a).
  for (Real tan_theta : {0.31, 0.45}) {
    SCOPED_TRACE(tan_theta);
    const InclineRun r = incline(tan_theta, 0.4, 0.5, 0.2, 0.3, 0.5, 1.0);
    const Real theta = std::atan(tan_theta), a = r.arm, R = kInclineRadius;
    const Real expected = kG * (std::sin(theta) - 0.2 * std::cos(theta) * R / a) / (1 + 0.4 * R * R / (a * a));
    EXPECT_GT(r.creep, 0.1 * R);
    EXPECT_NEAR(r.acceleration, expected, 1e-2 * expected);
  }
}

TEST(ContactPhysics, SphereSlidesDownWhenStaticFrictionIsExceeded) {
  // tan(theta) = 0.25 > mu_s = 0.2 while tan(theta) < mu_rs = 0.3: slides without rolling (the
  // friction torque mu F_n a stays below mu_rs R F_n), at g (sin - mu cos).
  const InclineRun r = incline(0.25, 0.15, 0.2, 0.2, 0.3, 0.5, 1.0);
  const Real theta = std::atan(0.25);
  const Real expected = kG * (std::sin(theta) - 0.15 * std::cos(theta));
  EXPECT_GT(r.creep, 0.1 * kInclineRadius);
  EXPECT_NEAR(r.acceleration, expected, 1e-2 * expected);
}

TEST(ContactPhysics, SphereWithoutRollingResistanceRollsDownAnyIncline) {
  // mu_r = mu_rs = 0: rolls without slip (tan(theta) = 0.1 < 3.5 mu_s) at g sin / (1 + kappa R^2 / a^2).
  const InclineRun r = incline(0.1, 0.4, 0.5, 0.0, 0.0, 0.5, 1.0);
  const Real theta = std::atan(0.1), a = r.arm, R = kInclineRadius;
  const Real expected = kG * std::sin(theta) / (1 + 0.4 * R * R / (a * a));
  EXPECT_GT(r.creep, 0.1 * R);
  EXPECT_NEAR(r.acceleration, expected, 1e-2 * expected);
}

// ---------------------------------------------------------------------------------------------
// 6.5 Rolling resistance: stopping distance on a flat, starting in rolling without slip

struct RollStop {
  Real stop_time;  // [s], speed extrapolated linearly to zero
  Real distance;   // [m], resting position after 1.3 stop times
  Real deceleration_oracle;
};

RollStop rolling_stop(int dimension, Real v0, Real mu_r) {
  const Real k = 1e6, mass = 1, radius = 0.05, dt = 1e-4;  // omega0 h = 0.1, delta0 / R = 2e-4
  const Real kappa = dimension == 3 ? 0.4 : 0.5;
  WorldConfig c = base_config(dt, dimension);
  const Vec3 up = dimension == 3 ? Vec3::UnitZ() : Vec3::UnitY();
  c.model.gravity = -kG * up;
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = k;
  law.normal_damping = {DampingKind::damping_ratio, 0.3};
  law.tangential_damping = {DampingKind::damping_ratio, 0.3};
  law.sliding_friction = 0.5;
  law.rolling_friction = mu_r;
  c.walls.push_back(plane(Vec3::Zero(), up));
  const Real delta0 = mass * kG / k, a = radius - 0.5 * delta0;
  ParticleConfig p = particle((radius - delta0) * up, Vec3(v0, 0, 0), radius, mass);
  // Rolling without slip: omega x (-a up) = -v  =>  omega = (v0 / a) (up x x).
  p.angular_velocity = (v0 / a) * up.cross(Vec3::UnitX());
  c.particles.push_back(p);
  World world(c);
  // Rolling: m dv/dt = F, I dw/dt = -a F - mu_r R F_n, v = a w  =>  dv/dt = -mu_r g R a / (kappa R^2 + a^2).
  const Real decel = mu_r * kG * radius * a / (kappa * radius * radius + a * a);
  const Real t_oracle = v0 / decel;
  RollStop r{0, 0, decel};
  Real t_prev = 0, v_prev = v0, t_prev2 = 0, v_prev2 = v0;
  long step = 0;
  while (dt * static_cast<Real>(step) < 1.3 * t_oracle) {
    advance(world, 1);
    ++step;
    const Real v = world.state().velocity[0].x();
    if (r.stop_time == 0) {
      if (v < 1e-2 * v0 && step > 2) {
        r.stop_time = t_prev + v_prev * (t_prev - t_prev2) / (v_prev2 - v_prev);
      } else {
        t_prev2 = t_prev, v_prev2 = v_prev;
        t_prev = dt * static_cast<Real>(step), v_prev = v;
      }
    }
  }
  r.distance = world.state().position[0].x();
  EXPECT_LT(std::abs(world.state().velocity[0].x()), 1e-4 * v0);  // at rest, held by the static spring
  return r;
}

TEST(ContactPhysics, RollingSphereStopsAtRollingResistanceDistance) {
  // 6.5: distance (1 + kappa) v^2 / (2 g mu_r) = 1.4 v^2 / (2 g mu_r) for a sphere (with a = R).
  const Real v0 = 1, mu_r = 0.1;
  const RollStop r = rolling_stop(3, v0, mu_r);
  EXPECT_NEAR(r.distance, v0 * v0 / (2 * r.deceleration_oracle), 5e-3 * v0 * v0 / (2 * r.deceleration_oracle));
  EXPECT_NEAR(r.distance, 1.4 * v0 * v0 / (2 * kG * mu_r), 5e-3 * 1.4 * v0 * v0 / (2 * kG * mu_r));
  EXPECT_NEAR(r.stop_time, v0 / r.deceleration_oracle, 5e-3 * v0 / r.deceleration_oracle);
}

TEST(ContactPhysics, RollingDiscStopsAtRollingResistanceDistance) {
  const Real v0 = 1, mu_r = 0.1;
  const RollStop r = rolling_stop(2, v0, mu_r);
  EXPECT_NEAR(r.distance, v0 * v0 / (2 * r.deceleration_oracle), 5e-3 * v0 * v0 / (2 * r.deceleration_oracle));
  EXPECT_NEAR(r.distance, 1.5 * v0 * v0 / (2 * kG * mu_r), 5e-3 * 1.5 * v0 * v0 / (2 * kG * mu_r));
  EXPECT_NEAR(r.stop_time, v0 / r.deceleration_oracle, 5e-3 * v0 / r.deceleration_oracle);
}

TEST(ContactPhysics, UndampedBouncingParticleShowsNoEnergyDriftOver1e4Periods) {
  const DriftResult r = bounce_between_walls(10'000);
  expect_no_drift(r);
  RecordProperty("max_energy_error", sci(r.max_error));
  RecordProperty("first_tenth_mean", sci(r.first_mean));
  RecordProperty("last_tenth_mean", sci(r.last_mean));
}

TEST(ContactPhysics, VerletKeepsEnergyOfCompressedPackingWithin1e3WithoutTrend) {
  // docs/physics.md 8.6 with velocity Verlet on many undamped contacts that persist (no gravity, zero
  // total momentum): |dE| <= 1e-3 of the initial kinetic + elastic energy at omega_max h = 0.3, with no
  // trend. Sharper, from the shadow energy (tests/contact_scenes.h): 0 <= dE <= (omega_max h)^2/4 of
  // the vibration energy, and the error is Verlet's own, second order in h.
  const WorldConfig c = persistent_packing_config(Method::verlet);
  const PackingRun r = run_packing(c, 0.3, 20'000);
  const PackingRun half_step = run_packing(c, 0.15, 20'000);
  record(r);
  EXPECT_EQ(r.contact_events, 0u);  // every contact persists: the system is linear
  EXPECT_LE(r.max_error, 1e-3);
  EXPECT_LE(r.max_error * r.initial_energy, 1.05 * 0.25 * 0.3 * 0.3 * r.initial_kinetic);
  EXPECT_GE(r.min_change, -1e-12);
  EXPECT_LE(r.last_mean, 1.2 * r.first_mean);
  EXPECT_NEAR(std::log2(r.max_error / half_step.max_error), 2.0, 0.2);
}

TEST(ContactPhysics, VerletEnergyErrorInUndampedPackingIsBoundedWithoutTrend) {
  // A packing that rearranges (a square lattice that buckles: contacts made and broken all the time).
  // Velocity Verlet (the fixed control's method). For a linear system it conserves
  // H - (h^2/8) sum F_i^2/m_i exactly, so |dE| <= (omega_max h)^2/4 of the elastic energy; contacts
  // made and broken add zero-mean kink errors of the same order (kUndampedC; docs/physics.md 8.6).
  // Bound: (omega_max h)^2 / 4 = 2.25e-2. No trend: a linear drift from 0 gives last/first ~ 19, a random
  // walk of kink errors ~ 4.5, a bounded oscillation ~ 1; require <= 8.
  const PackingRun r = run_packing(Method::verlet, 0.3, 20'000);
  record(r);
  EXPECT_LE(r.max_error, 0.25 * 0.3 * 0.3);
  EXPECT_LE(r.last_mean, 8 * r.first_mean);
  EXPECT_GT(r.contact_events, 10u);  // the packing does make and break contacts
  EXPECT_LE(r.omega_max_h_run, 0.4);
}

TEST(ContactPhysics, ExactMethodKeepsPackingEnergyWithin3e2AtOmegaMaxDt15) {
  // docs/physics.md 8.6, scheme (D) at omega_max h = 1.5, beyond Verlet's stability limit for the packing:
  // |dE| <= 3e-2 of the initial kinetic + elastic energy, with no trend.
  const PackingRun r = run_packing(Method::exact, 1.5, 20'000);
  record(r);
  EXPECT_LE(r.max_error, 3e-2);
  EXPECT_LE(r.last_mean, 8 * r.first_mean);
}

TEST(ContactPhysics, ExactMethodKeepsPackingEnergyWithin1e3AtOmegaMaxDt03) {
  // docs/physics.md 8.6 for scheme (D), the multi-contact exact stepper (docs/physics.md 5.4):
  // |dE| <= 1e-3 of the initial kinetic + elastic energy at omega_max h = 0.3, with no trend.
  const PackingRun r = run_packing(Method::exact, 0.3, 20'000);
  record(r);
  EXPECT_LE(r.max_error, 1e-3);
  EXPECT_LE(r.last_mean, 8 * r.first_mean);
}

// ---------------------------------------------------------------------------------------------
// 6.7 Linear momentum with friction, rolling resistance and damping, particle-particle only

TEST(ContactPhysics, LinearMomentumIsConservedToRoundOffWithFrictionAndRolling) {
  WorldConfig c = base_config(2e-5);
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = 1e5;
  law.normal_damping = {DampingKind::restitution, 0.5};
  law.tangential_damping = {DampingKind::damping_ratio, 0.3};
  law.sliding_friction = 0.4;
  law.static_friction = 0.5;
  law.rolling_friction = 0.05;
  law.rolling_static_friction = 0.08;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<Real> u(-1, 1);
  // 3 x 3 x 3 grid less 3 corners, spacing 0.03 m, radii 0.007 ... 0.013 m (no initial overlap),
  // masses from the density (unequal, inexact inverses), converging at ~0.6 m/s, random spins.
  for (int i = 0; i < 24; ++i) {
    ParticleConfig p;
    p.radius = 0.01 * (1 + 0.3 * u(rng));
    p.position = Vec3(i % 3 - 1, (i / 3) % 3 - 1, i / 9 - 1) * 0.03;
    p.velocity = -20.0 * p.position + Vec3(u(rng), u(rng), u(rng)) * 0.2;
    p.angular_velocity = Vec3(u(rng), u(rng), u(rng)) * 50;
    c.particles.push_back(p);
  }
  World world(c);
  const Vec3 p0 = world.linear_momentum();
  const Real e0 = world.energies().kinetic + world.energies().rotational;
  Real scale = 0;  // sum m |v|
  for (std::size_t i = 0; i < world.state().size(); ++i)
    scale += world.state().velocity[i].norm() / world.state().inv_mass[i];
  Real worst = 0;
  std::size_t max_contacts = 0;
  for (int chunk = 0; chunk < 100; ++chunk) {
    advance(world, 30);
    worst = std::max(worst, (world.linear_momentum() - p0).norm() / scale);
    max_contacts = std::max(max_contacts, world.pair_contacts().size());
  }
  RecordProperty("max_relative_momentum_error", sci(worst));
  EXPECT_LE(worst, 1e-13);
  EXPECT_GE(max_contacts, 5u);  // the cluster did collide
  // Kinetic energy was lost (damping, sliding, rolling): the contacts acted.
  EXPECT_LT(world.energies().kinetic + world.energies().rotational, 0.9 * e0);
}

// ---------------------------------------------------------------------------------------------
// 6.6 Convergence order of velocity Verlet (undamped): least squares over 5 steps spanning 16x, the
// error at each step the maximum over 8 onset phases x 5 stiffnesses within +-10%.

Real least_squares_order(const std::vector<Real>& h, const std::vector<Real>& err) {
  Real n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t i = 0; i < h.size(); ++i) {
    const Real x = std::log(h[i]), y = std::log(err[i]);
    n += 1, sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

const std::vector<Real> kOrderStiffnessFactors = {0.9, 0.95, 1.0, 1.05, 1.1};
const std::vector<Real> kOrderPhases = {0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875};

// Undamped head-on collision (m = 1 each): error in the relative coordinate and velocity after
// separation against the exact solution r(t) = 2R + v (t - t_on - pi/omega0), dr/dt = v.
Real collision_error(Real k, Real dt, Real phase) {
  const Real m = 1, radius = 0.05, v = 1, omega0 = std::sqrt(k / (0.5 * m));
  WorldConfig c = base_config(dt);
  c.contacts[0].normal_stiffness = k;
  const Real gap = v * (3 + phase) * dt, t_on = gap / v;
  c.particles.push_back(particle(Vec3(-(radius + 0.5 * gap), 0, 0), Vec3(0.5 * v, 0, 0), radius, m));
  c.particles.push_back(particle(Vec3(radius + 0.5 * gap, 0, 0), Vec3(-0.5 * v, 0, 0), radius, m));
  World world(c);
  const long steps = static_cast<long>(std::ceil((t_on + 1.5 * pi / omega0) / dt));
  advance(world, steps);
  const Real t = dt * static_cast<Real>(steps);
  const State& s = world.state();
  const Real r = s.position[1].x() - s.position[0].x(), rdot = s.velocity[1].x() - s.velocity[0].x();
  const Real r_exact = 2 * radius + v * (t - t_on - pi / omega0);
  EXPECT_EQ(world.pair_contacts().size(), 0u);
  return std::abs(r - r_exact) * omega0 / v + std::abs(rdot - v) / v;
}

// Sphere (m = 1) pressed on a floor by gravity, oscillating about equilibrium without losing
// contact: z(t) = z_eq + A cos(omega0 t + psi). Error at a fixed time T = n0 h0.
Real persistent_error(Real k, Real dt, long steps, Real psi) {
  const Real m = 1, radius = 0.05, g = 9.81, omega0 = std::sqrt(k / m);
  const Real delta_eq = m * g / k, amplitude = 0.5 * delta_eq, z_eq = radius - delta_eq;
  WorldConfig c = base_config(dt);
  c.model.gravity = Vec3(0, 0, -g);
  c.contacts[0].normal_stiffness = k;
  c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitZ()));
  c.particles.push_back(particle(Vec3(0, 0, z_eq + amplitude * std::cos(psi)),
                                 Vec3(0, 0, -amplitude * omega0 * std::sin(psi)), radius, m));
  World world(c);
  advance(world, steps);
  const Real t = dt * static_cast<Real>(steps);
  const Real z = z_eq + amplitude * std::cos(omega0 * t + psi);
  const Real w = -amplitude * omega0 * std::sin(omega0 * t + psi);
  EXPECT_EQ(world.wall_contacts().size(), 1u);
  return std::abs(world.state().position[0].z() - z) / amplitude +
         std::abs(world.state().velocity[0].z() - w) / (amplitude * omega0);
}

TEST(ContactPhysics, VerletConvergesAtSecondOrderOnUndampedCollision) {
  const Real k_ref = 1e5, omega_ref = std::sqrt(k_ref / 0.5);
  std::vector<Real> hs, errs;
  for (int level = 0; level < 5; ++level) {  // omega0 h = 0.2 ... 0.0125
    const Real dt = 0.2 / omega_ref / static_cast<Real>(1 << level);
    Real worst = 0;
    for (Real f : kOrderStiffnessFactors)
      for (Real phase : kOrderPhases) worst = std::max(worst, collision_error(f * k_ref, dt, phase));
    hs.push_back(dt);
    errs.push_back(worst);
  }
  const Real order = least_squares_order(hs, errs);
  RecordProperty("order", sci(order));
  EXPECT_GE(order, 1.8);
  EXPECT_LE(order, 2.5);  // not a spuriously small error at the fine end
}

TEST(ContactPhysics, VerletConvergesAtSecondOrderOnPersistentContact) {
  const Real k_ref = 1e5, omega_ref = std::sqrt(k_ref);
  const Real h0 = 0.2 / omega_ref;
  const long n0 = static_cast<long>(std::ceil(5 * 2 * pi / omega_ref / h0));  // about 5 periods
  std::vector<Real> hs, errs;
  for (int level = 0; level < 5; ++level) {
    const Real dt = h0 / static_cast<Real>(1 << level);
    Real worst = 0;
    for (Real f : kOrderStiffnessFactors)
      for (Real phase : kOrderPhases) worst = std::max(worst, persistent_error(f * k_ref, dt, n0 << level, 2 * pi * phase));
    hs.push_back(dt);
    errs.push_back(worst);
  }
  const Real order = least_squares_order(hs, errs);
  RecordProperty("order", sci(order));
  EXPECT_GE(order, 1.8);
  EXPECT_LE(order, 2.5);
}

// ---------------------------------------------------------------------------------------------
// 2-D: discs stay in the xy plane and spin only about z, even when the scene offers out-of-plane
// components (initial z, v_z, omega_x,y; a floor whose normal has a z component).

TEST(ContactPhysics, DiscSceneKeepsZeroZAndSpinOnlyAboutZ) {
  WorldConfig c = base_config(2e-5, 2);
  c.model.thickness = 0.01;
  c.model.gravity = Vec3(0, -9.81, 0);
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = 1e4;
  law.normal_damping = {DampingKind::restitution, 0.5};
  law.sliding_friction = 0.5;
  law.rolling_friction = 0.05;
  WallConfig drum;
  drum.kind = WallKind::cylinder;
  drum.radius = 0.2;
  drum.angular_velocity = Vec3(0, 0, 3.0);
  c.walls.push_back(drum);
  c.walls.push_back(plane(Vec3(0, -0.15, 0), Vec3(0.2, 1.0, 0.3)));
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<Real> u(-1, 1);
  for (int i = 0; i < 16; ++i) {
    ParticleConfig p;
    p.radius = 0.015 * (1 + 0.2 * u(rng));
    p.position = Vec3(0.08 * u(rng), 0.05 + 0.07 * u(rng), 0.01 * u(rng));
    p.velocity = Vec3(u(rng), u(rng), u(rng));
    p.angular_velocity = Vec3(u(rng), u(rng), u(rng)) * 10;
    c.particles.push_back(p);
  }
  World world(c);
  Real max_spin = 0;
  std::size_t max_contacts = 0;
  for (int chunk = 0; chunk < 50; ++chunk) {
    advance(world, 500);  // 0.5 s in all
    const State& s = world.state();
    for (std::size_t i = 0; i < s.size(); ++i) {
      ASSERT_EQ(s.position[i].z(), 0.0) << i;
      ASSERT_EQ(s.velocity[i].z(), 0.0) << i;
      ASSERT_EQ(s.angular_velocity[i].x(), 0.0) << i;
      ASSERT_EQ(s.angular_velocity[i].y(), 0.0) << i;
      max_spin = std::max(max_spin, std::abs(s.angular_velocity[i].z()));
    }
    max_contacts = std::max(max_contacts, world.pair_contacts().size() + world.wall_contacts().size());
  }
  EXPECT_GT(max_spin, 1.0);      // friction and the drum did spin the discs
  EXPECT_GE(max_contacts, 4u);   // and they touched walls and each other
}

// ---------------------------------------------------------------------------------------------
// Walls

TEST(ContactPhysics, BoxContainerKeepsParticlesInside) {
  WorldConfig c = base_config(2e-5);
  c.model.gravity = Vec3(0, 0, -9.81);
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = 1e5;
  law.normal_damping = {DampingKind::restitution, 0.9};
  law.sliding_friction = 0.3;
  WallConfig box;
  box.kind = WallKind::box;
  box.inside = true;
  box.half_extents = Vec3(0.1, 0.08, 0.06);
  c.walls.push_back(box);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<Real> u(-1, 1);
  const Real radius = 0.01;
  for (int i = 0; i < 20; ++i) {
    ParticleConfig p;
    p.radius = radius;
    p.position = Vec3(0.08 * u(rng), 0.06 * u(rng), 0.04 * u(rng));
    p.velocity = Vec3(u(rng), u(rng), u(rng)) * 3.0;
    c.particles.push_back(p);
  }
  World world(c);
  // Any one overlap stores at most the whole available energy: (1/2) k delta^2 <= E_kin + E_pot above
  // the floor, E_pot measured from the lowest possible centre height.
  const State& s = world.state();
  Real available = world.energies().kinetic;
  for (std::size_t i = 0; i < s.size(); ++i) available += 9.81 * (s.position[i].z() + 0.06) / s.inv_mass[i];
  const Real delta_bound = 1.1 * std::sqrt(2 * available / law.normal_stiffness);
  for (int chunk = 0; chunk < 250; ++chunk) {
    advance(world, 100);  // 0.5 s in all
    for (std::size_t i = 0; i < s.size(); ++i)
      for (int a = 0; a < 3; ++a)
        ASSERT_LE(std::abs(s.position[i][a]), box.half_extents[a] - radius + delta_bound)
            << "particle " << i << " axis " << a << " at t = " << world.time();
  }
  // Damping and friction settle them on the floor: all centres at most a radius above it, roughly.
  EXPECT_GT(world.counters().sync_intervals, 0u);
}

// Cylinder inner wall turning at Omega about its axis: at the bottom its surface moves at Omega R_c
// along +x (Omega > 0). A resting particle slides against it, so friction mu m g accelerates it in
// the surface's direction: v_x(t) = mu g t while sliding (the climb up the curve changes this by
// g phi ~ 0.1% over 20 ms).
TEST(ContactPhysics, TurningCylinderWallDragsRestingParticleAlong) {
  for (Real omega : {2.0, -2.0}) {
    SCOPED_TRACE(omega);
    const Real mass = 0.1, radius = 0.02, k = 1e5, mu = 0.3, g = 9.81, cyl = 0.5;
    WorldConfig c = base_config(1e-4);  // omega0 h = 0.1
    c.model.gravity = Vec3(0, -g, 0);
    ContactConfig& law = c.contacts[0];
    law.normal_stiffness = k;
    law.normal_damping = {DampingKind::damping_ratio, 0.3};
    law.sliding_friction = mu;
    WallConfig drum;
    drum.kind = WallKind::cylinder;
    drum.radius = cyl;
    drum.angular_velocity = Vec3(0, 0, omega);
    c.walls.push_back(drum);
    c.particles.push_back(particle(Vec3(0, -(cyl - radius + mass * g / k), 0), Vec3::Zero(), radius, mass));
    World world(c);
    advance(world, 200);
    const Real t = 0.02;
    const Real expected = (omega > 0 ? 1 : -1) * mu * g * t;
    EXPECT_NEAR(world.state().velocity[0].x(), expected, 0.02 * std::abs(expected));
    EXPECT_LT(std::abs(world.state().velocity[0].x()), std::abs(omega) * cyl);
  }
}

TEST(ContactPhysics, WallLoadOfRestingParticlesEqualsTheirWeight) {
  const Real g = 9.81, k = 1e5;
  WorldConfig c = base_config(1e-4);
  c.model.gravity = Vec3(0, 0, -g);
  c.contacts[0].normal_stiffness = k;
  c.contacts[0].normal_damping = {DampingKind::damping_ratio, 0.5};
  c.contacts[0].sliding_friction = 0.3;
  c.walls.push_back(plane(Vec3(0, 0, -0.1), Vec3::UnitZ()));
  const std::vector<Real> masses = {0.5, 1.0, 2.5};
  const std::vector<Vec3> spots = {Vec3(0.3, 0.1, 0), Vec3(-0.2, 0.4, 0), Vec3(0.1, -0.5, 0)};
  Real weight = 0;
  Vec3 torque = Vec3::Zero();  // about the plane's point (its rotation centre)
  for (std::size_t i = 0; i < masses.size(); ++i) {
    c.particles.push_back(particle(spots[i] + Vec3(0, 0, -0.1 + 0.05 + 0.001), Vec3::Zero(), 0.05, masses[i]));
    weight += masses[i] * g;
    torque += (spots[i] - Vec3::Zero()).cross(Vec3(0, 0, -masses[i] * g));
  }
  World world(c);
  advance(world, 20'000);  // 2 s: drop 1 mm, settle with zeta = 0.5 (omega0 >= 200 1/s)
  const WallLoad load = world.wall_load(0);
  EXPECT_NEAR(load.force.z(), -weight, 1e-9 * weight);
  EXPECT_NEAR(load.force.x(), 0.0, 1e-9 * weight);
  EXPECT_NEAR(load.force.y(), 0.0, 1e-9 * weight);
  EXPECT_NEAR((load.torque - torque).norm(), 0.0, 1e-8 * torque.norm());
}

}  // namespace
}  // namespace dem
