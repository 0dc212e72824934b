// Friction and rolling resistance on pair contacts and cylinder walls in the exact stepper
// (tangential_kick.h, exact_stepper.h; docs/physics.md 2.3-2.5, 5.6): an oblique frictional collision of two
// spheres against velocity Verlet at a very small step (independent methods) and the exact stepper at a
// step longer than the contact against itself at a small one; the gross-slip collision against the
// Coulomb impulse result; linear and angular momentum to round-off in a frictional cluster; a ball
// sliding into rolling inside a fixed cylinder and one dragged by a spinning cylinder against Verlet,
// with the energy books closing; the spring energy in the World's elastic energy; the same state hash
// for one, two and three threads.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/test_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

constexpr Real radius = 0.05, mass = 1;  // [m], [kg]

/// Two equal spheres; contact with stiffness k, damping ratio zeta (normal and tangential), friction mu
/// (static = sliding) and rolling resistance mu_r.
WorldConfig pair_config(Method method, Real dt, Real k, Real zeta, Real mu, Real mu_r) {
  WorldConfig c;
  c.threads = 1;
  c.integrator.method = method;
  c.integrator.dt = dt;
  ContactConfig& contact = c.contacts[0];
  contact.normal_stiffness = k;
  contact.normal_damping = {DampingKind::damping_ratio, zeta};
  contact.tangential_damping = {DampingKind::damping_ratio, zeta};
  contact.sliding_friction = mu;
  contact.rolling_friction = mu_r;
  return c;
}

/// Particle 0 at -x, particle 1 at +x, a gap of 1 mm, approaching along x at v_n and sliding past each
/// other along y at v_t (relative velocities of 0 against 1), with spins.
void add_oblique_pair(WorldConfig& c, Real v_n, Real v_t, const Vec3& spin_0, const Vec3& spin_1) {
  const Real half_gap = 0.5e-3;
  ParticleConfig a = test::particle(Vec3(-(radius + half_gap), 0, 0), Vec3(0.5 * v_n, 0.5 * v_t, 0), radius, mass);
  ParticleConfig b = test::particle(Vec3(radius + half_gap, 0, 0), Vec3(-0.5 * v_n, -0.5 * v_t, 0), radius, mass);
  a.angular_velocity = spin_0;
  b.angular_velocity = spin_1;
  c.particles = {a, b};
}

struct PairEnd {
  Vec3 v0, v1, w0, w1;
  Real balance;  // largest |energy balance error| / scale over the run
};

/// Runs w for `until` seconds of its fixed step; returns the largest |energy balance error| / scale.
Real run_audited_balance(World& w, Real until) {
  const long steps = std::lround(until / w.config().integrator.dt);
  Real worst = 0;
  for (long s = 0; s < steps; ++s) {
    EXPECT_EQ(w.advance_sync_interval(), StepStatus::ok);
    const EnergyBalance b = w.energy_balance();
    worst = std::max(worst, std::abs(b.error) / b.scale);
  }
  return worst;
}

PairEnd run_pair(const WorldConfig& c, Real until) {
  World w(c);
  const Real worst = run_audited_balance(w, until);
  return {w.velocity(0), w.velocity(1), w.angular_velocity(0), w.angular_velocity(1), worst};
}

/// Largest difference between two ends, velocities in m/s and spins times the radius (m/s).
Real difference(const PairEnd& a, const PairEnd& b) {
  return std::max({(a.v0 - b.v0).norm(), (a.v1 - b.v1).norm(), radius * (a.w0 - b.w0).norm(),
                   radius * (a.w1 - b.w1).norm()});
}

TEST(ExactPairFriction, ObliqueCollisionAgreesWithVerletAndAcrossSteps) {
  // k = 1e5, m* = 0.5: omega0 = 447 1/s, contact about t_c = 6.6 ms. Relative speeds 1 m/s along the
  // normal and 0.3 m/s (slip ends within the contact: stick, roll) or 2.5 m/s (gross slip: slides
  // throughout) across it, spins out of the collision plane, rolling resistance on. Verlet at t_c / 4000
  // is the reference; the exact stepper at t_c / 40 and at about one contact per step.
  const Real t_c = 6.6e-3, until = 4 * t_c;
  for (const Real v_t : {0.3, 2.5}) {
    WorldConfig base = pair_config(Method::verlet, until / 16000, 1e5, 0.1, 0.3, 0.02);
    add_oblique_pair(base, 1.0, v_t, Vec3(2, -3, 5), Vec3(-4, 1, 0));
    const PairEnd reference = run_pair(base, until);
    WorldConfig fine = base, coarse = base;
    fine.integrator.method = coarse.integrator.method = Method::exact;
    fine.integrator.dt = until / 160;
    coarse.integrator.dt = until / 4;
    const PairEnd exact_fine = run_pair(fine, until), exact_coarse = run_pair(coarse, until);
    const Real scale = 1.0;  // [m/s], the impact speed
    std::printf("  v_t %.1f: |exact(t_c/40) - verlet(t_c/4000)| = %.3e, |exact(t_c) - exact(t_c/40)| = %.3e m/s; "
                "balance verlet %.1e exact %.1e %.1e; exit v0 = (%.5f %.5f %.5f), w0 = (%.4f %.4f %.4f)\n",
                v_t, difference(exact_fine, reference), difference(exact_coarse, exact_fine), reference.balance,
                exact_fine.balance, exact_coarse.balance, reference.v0.x(), reference.v0.y(), reference.v0.z(),
                reference.w0.x(), reference.w0.y(), reference.w0.z());
    EXPECT_LT(difference(exact_fine, reference), 2e-4 * scale) << "v_t " << v_t;
    EXPECT_LT(difference(exact_coarse, exact_fine), 2e-3 * scale) << "v_t " << v_t;
    // The books close: kinetic + elastic (tangential and rolling springs included) + dissipated.
    EXPECT_LT(exact_fine.balance, 1e-11) << "v_t " << v_t;
    EXPECT_LT(exact_coarse.balance, 1e-11) << "v_t " << v_t;
  }
}

TEST(ExactPairFriction, StepDoublingCarriesThePairHistory) {
  // Under step doubling the islands carry the pair's springs and modes, keyed by particle ids, through
  // their trials: the stick-slip collision of the test above ends as with the fixed control at t_c / 40.
  const Real t_c = 6.6e-3, until = 4 * t_c;
  WorldConfig fixed = pair_config(Method::exact, until / 160, 1e5, 0.1, 0.3, 0.02);
  add_oblique_pair(fixed, 1.0, 0.3, Vec3(2, -3, 5), Vec3(-4, 1, 0));
  const PairEnd reference = run_pair(fixed, until);
  WorldConfig c = fixed;
  c.integrator.control = Control::doubling;
  c.integrator.dt = c.integrator.dt_base = until / 16;
  c.integrator.tolerance = 1e-5;
  c.integrator.level_min = -8;
  c.integrator.level_max = 0;
  World w(c);
  for (int k = 0; k < 16; ++k) ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
  const State& s = w.state();
  const PairEnd end{s.velocity[0], s.velocity[1], s.angular_velocity[0], s.angular_velocity[1], 0};
  std::printf("  doubling: |exact doubling - exact(t_c/40)| = %.3e m/s, accepted %llu rejected %llu\n",
              difference(end, reference), static_cast<unsigned long long>(w.counters().accepted_steps),
              static_cast<unsigned long long>(w.counters().rejected_steps));
  EXPECT_NEAR(w.time(), until, 1e-12);
  EXPECT_LT(difference(end, reference), 1e-3);
  const EnergyBalance b = w.energy_balance();
  EXPECT_LT(std::abs(b.error) / b.scale, 1e-9);
}

TEST(ExactPairFriction, GrossSlipMatchesTheCoulombImpulse) {
  // Two solid spheres sliding throughout a collision (mu = mu_s): the tangential impulse is mu times the
  // normal impulse J_n, against the slip. With m_i = m_j = m the relative centre velocity changes by
  // J (1/m_i + 1/m_j), so its tangential change is mu times its normal change (1 + e) v_n, whatever the
  // lever arms; each spin changes by a J_t / I (a = R - delta/2), so the slip u = v_rel - (a w_i + a w_j)
  // x n changes by J_t (2/m)(1 + a^2 m / I) = 7/2 mu (1 + e) v_n for a = R (kappa = 2/5). Stiff contact
  // (k = 1e7: delta_max / R = 0.1%), mu = 0.2, v_n = 0.2 m/s, slip 0.5 m/s > 7/2 mu (1 + e) v_n =
  // 0.24 m/s; the centres line up along x in the middle of the contact, so the normal turns by +-2e-3 rad
  // about x; at steps of t_c / 40 and 2 t_c.
  const Real v_n = 0.2, v_t = 0.5, mu = 0.2, t_c = 0.7e-3, gap = 0.1e-3, meet = gap / v_n + 0.5 * t_c;
  for (const Real dt : {t_c / 40, 2 * t_c}) {
    WorldConfig c = pair_config(Method::exact, dt, 1e7, 0.1, mu, 0);
    add_oblique_pair(c, v_n, v_t, Vec3::Zero(), Vec3::Zero());
    c.particles[0].position = Vec3(-(radius + 0.5 * gap), -0.5 * v_t * meet, 0);
    c.particles[1].position = Vec3(radius + 0.5 * gap, 0.5 * v_t * meet, 0);
    const PairEnd end = run_pair(c, meet + 8 * t_c);
    const Vec3 v_rel = end.v0 - end.v1;
    const Real dv_n = v_n - v_rel.x();  // (1 + e) v_n
    const Real dv_t = v_t - v_rel.y();
    const Vec3 n(-1, 0, 0);           // from 1 to 0
    const Vec3 slip = v_rel - (radius * end.w0 + radius * end.w1).cross(n);
    const Real dslip = v_t - slip.y();
    std::printf("  dt %.2e: (1 + e) v_n = %.6f, d v_t / (mu (1 + e) v_n) = %.6f, d slip / (7/2 mu (1 + e) v_n) = "
                "%.6f, out of plane %.1e\n",
                dt, dv_n, dv_t / (mu * dv_n), dslip / (3.5 * mu * dv_n), std::abs(v_rel.z()));
    EXPECT_GT(dv_n, v_n) << "a rebound";
    EXPECT_NEAR(dv_t / (mu * dv_n), 1, 3e-3) << "dt " << dt;
    EXPECT_NEAR(dslip / (3.5 * mu * dv_n), 1, 3e-3) << "dt " << dt;
    EXPECT_GT(slip.y(), 0) << "still slipping at the end";
    EXPECT_LT(std::abs(v_rel.z()), 1e-12);
  }
}

TEST(ExactPairFriction, TangentialImpulseNeverExceedsMuTimesTheNormalImpulse) {
  // The stick-slip case (slip ends within the contact): |J_t| <= mu J_n, with equality only for gross slip.
  const Real v_n = 0.2, mu = 0.2, t_c = 0.7e-3;
  for (const Real v_t : {0.05, 0.1, 0.2}) {
    WorldConfig c = pair_config(Method::exact, t_c / 10, 1e7, 0.1, mu, 0);
    add_oblique_pair(c, v_n, v_t, Vec3::Zero(), Vec3::Zero());
    const PairEnd end = run_pair(c, 0.5e-3 / v_n + 8 * t_c);
    const Vec3 v_rel = end.v0 - end.v1;
    const Real j_n = 0.5 * mass * (v_n - v_rel.x()), j_t = 0.5 * mass * std::hypot(v_t - v_rel.y(), v_rel.z());
    std::printf("  v_t %.2f: J_t / (mu J_n) = %.6f\n", v_t, j_t / (mu * j_n));
    EXPECT_LE(j_t, mu * j_n * (1 + 1e-3)) << "v_t " << v_t;
    EXPECT_GT(j_t, 0) << "v_t " << v_t;
  }
}

/// Angular momentum about the origin [kg m^2/s] and linear momentum [kg m/s] of all particles.
void momenta(const World& w, Vec3& linear, Vec3& angular, Real& scale) {
  const State& s = w.state();
  linear.setZero();
  angular.setZero();
  scale = 0;
  for (std::size_t p = 0; p < s.size(); ++p) {
    const Real m = 1 / s.inv_mass[p], inertia = 1 / s.inv_inertia[p];
    linear += m * s.velocity[p];
    angular += m * s.position[p].cross(s.velocity[p]) + inertia * s.angular_velocity[p];
    scale += m * s.position[p].norm() * s.velocity[p].norm() + inertia * s.angular_velocity[p].norm();
  }
}

TEST(ExactPairFriction, ClusterConservesLinearAndAngularMomentumToRoundOff) {
  // 27 spheres of unequal sizes and masses thrown together with spins, friction, static friction above
  // sliding and rolling resistance, no gravity or walls: every pair flow applies equal and opposite
  // impulses at a common contact point, so momentum about a fixed point stays to round-off.
  WorldConfig c = pair_config(Method::exact, 2e-4, 1e5, 0.2, 0.4, 0.05);
  c.contacts[0].static_friction = 0.6;
  std::uint64_t draw = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) {
        const Vec3 x(0.105 * (i - 1) + 0.3, 0.105 * (j - 1) - 0.2, 0.105 * (k - 1) + 0.1);
        const Real r = 0.04 + 0.01 * test::uniform(7, draw++), m = 0.5 + test::uniform(7, draw++);
        Vec3 v = -2 * (x - Vec3(0.3, -0.2, 0.1));
        for (int d = 0; d < 3; ++d) v[d] += test::uniform(7, draw++) - 0.5;
        ParticleConfig p = test::particle(x, v, r, m);
        for (int d = 0; d < 3; ++d) p.angular_velocity[d] = 40 * (test::uniform(7, draw++) - 0.5);
        c.particles.push_back(p);
      }
  World w(c);
  Vec3 p0, l0, p1, l1;
  Real scale0, scale1;
  momenta(w, p0, l0, scale0);
  std::uint64_t most_contacts = 0;
  for (int s = 0; s < 500; ++s) {
    ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
    most_contacts = std::max<std::uint64_t>(most_contacts, w.pair_contacts().size());
  }
  momenta(w, p1, l1, scale1);
  std::printf("  |dP| = %.2e (of %.2e), |dL| = %.2e (of %.2e), most contacts %llu\n", (p1 - p0).norm(), scale0,
              (l1 - l0).norm(), scale0, static_cast<unsigned long long>(most_contacts));
  EXPECT_GE(most_contacts, 8u) << "the cluster collides";
  EXPECT_LT((p1 - p0).norm(), 1e-13 * scale0);
  EXPECT_LT((l1 - l0).norm(), 1e-12 * scale0);
}

/// A ball (R = 5 cm, 1 kg) resting at the bottom of a cylinder of radius 0.5 m (axis z, gravity -y)
/// spinning at `spin` rad/s, launched along x at v0; k = 1e5, zeta 0.3, mu = 0.3, mu_r = 0.01.
WorldConfig cylinder_config(Method method, Real dt, Real v0, Real spin) {
  WorldConfig c = pair_config(method, dt, 1e5, 0.3, 0.3, 0.01);
  c.model.gravity = Vec3(0, -9.81, 0);
  WallConfig shell;
  shell.kind = WallKind::cylinder;
  shell.radius = 0.5;
  shell.angular_velocity = Vec3(0, 0, spin);
  c.walls = {shell};
  const Real sag = mass * 9.81 / 1e5;
  c.particles = {test::particle(Vec3(0, -(0.5 - radius + sag), 0), Vec3(v0, 0, 0), radius, mass)};
  return c;
}

struct BallEnd {
  Vec3 x, v, w;
  Real balance;
};

BallEnd run_ball(const WorldConfig& c, Real until) {
  World w(c);
  const Real worst = run_audited_balance(w, until);
  return {w.state().position[0], w.state().velocity[0], w.state().angular_velocity[0], worst};
}

TEST(ExactCylinderFriction, BallInsideACylinderAgreesWithVerlet) {
  // Launched sliding at 1 m/s in a fixed shell: friction spins it up until it rolls, and it swings as a
  // rolling pendulum; at rest in a shell spinning at 2 rad/s: dragged up the side until it slips, or rolls
  // back. Verlet at 1e-5 s (omega0 h = 0.003) against the exact stepper at 1e-3 s and 1e-2 s (omega0 h =
  // 3.2, beyond the Cundall limit 2) after 0.8 s.
  for (const auto& [v0, spin] : {std::pair{1.0, 0.0}, std::pair{0.0, 2.0}}) {
    const Real until = 0.8;
    const BallEnd reference = run_ball(cylinder_config(Method::verlet, 1e-5, v0, spin), until);
    const BallEnd fine = run_ball(cylinder_config(Method::exact, 1e-3, v0, spin), until);
    const BallEnd coarse = run_ball(cylinder_config(Method::exact, 1e-2, v0, spin), until);
    const auto gap = [](const BallEnd& a, const BallEnd& b) {
      return std::max({(a.x - b.x).norm() / 0.1, (a.v - b.v).norm(), radius * (a.w - b.w).norm()});
    };
    std::printf("  v0 %.1f spin %.1f: end x = (%.5f %.5f), v = (%.5f %.5f), w_z = %.4f; |exact(1e-3) - verlet| = "
                "%.2e, |exact(1e-2) - verlet| = %.2e; balance verlet %.1e exact %.1e %.1e\n",
                v0, spin, reference.x.x(), reference.x.y(), reference.v.x(), reference.v.y(), reference.w.z(),
                gap(fine, reference), gap(coarse, reference), reference.balance, fine.balance, coarse.balance);
    EXPECT_LT(gap(fine, reference), 2e-3) << "v0 " << v0 << " spin " << spin;
    EXPECT_LT(gap(coarse, reference), 1e-2) << "v0 " << v0 << " spin " << spin;
    // Gravity on one side turns with the normal in the polar flow: energy is kept to second order there
    // (exact_stepper.h), so the books close to that order, well below Verlet's.
    EXPECT_LT(fine.balance, 1e-5);
    EXPECT_LT(coarse.balance, 1e-5);
    EXPECT_GT(reference.w.norm(), 1.0) << "friction turned the ball";
  }
}

TEST(ExactPairFriction, SpringEnergyIsPartOfTheElasticEnergy) {
  // A ball held at rest on a slope by friction and rolling resistance: its springs balance gravity,
  // F_t = m g sin(theta) (xi = F_t / k_t) and the rolling spring takes the moment a F_t (theta_r = a F_t /
  // k_r), so the World's elastic energy is k delta^2 / 2 + F_t^2 / (2 k_t) + (a F_t)^2 / (2 k_r), with
  // delta = m g cos(theta) / k. The slope is an immovable sphere (a pair contact) of radius 100 m.
  const Real k = 1e5, g = 9.81, big = 100, angle = 0.15;  // tan(angle) < mu_s, mu_rs
  WorldConfig c = pair_config(Method::exact, 1e-3, k, 0.7, 0.5, 0.3);
  c.model.gravity = Vec3(0, 0, -g);
  const Vec3 n(std::sin(angle), 0, std::cos(angle));  // from the big sphere to the ball
  const Real delta = mass * g * std::cos(angle) / k;
  c.particles = {test::particle(Vec3::Zero(), Vec3::Zero(), big, std::numeric_limits<Real>::infinity()),
                 test::particle((big + radius - delta) * n, Vec3::Zero(), radius, mass)};
  World w(c);
  for (int s = 0; s < 4000; ++s) ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
  const Real f_t = mass * g * std::sin(angle), k_t = 2 * k / 7, arm = radius - 0.5 * delta;
  const Real r_star = 1 / (1 / radius + 1 / big), k_r = k_t * r_star * r_star;
  const Real oracle = 0.5 * k * delta * delta + 0.5 * f_t * f_t / k_t + 0.5 * arm * arm * f_t * f_t / k_r;
  const Real elastic = w.energies().elastic;
  std::printf("  elastic %.6e J, oracle %.6e J (normal %.3e), speed %.1e m/s\n", elastic, oracle,
              0.5 * k * delta * delta, w.state().velocity[1].norm());
  EXPECT_LT(w.state().velocity[1].norm(), 1e-5) << "held at rest";
  EXPECT_NEAR(elastic, oracle, 2e-3 * oracle);
}

TEST(ExactPairFriction, SameStateHashForOneTwoAndThreeThreads) {
  const test::AllowThreads allow_three(3);
  std::uint64_t hash[3];
  for (const int threads : {1, 2, 3}) {
    // 18 spheres with friction and rolling resistance falling into a box: pair and wall contacts form
    // and end, in colours of several contacts each.
    WorldConfig c = test::falling_box_scene(3, 2, 3, 11);
    c.integrator.method = Method::exact;
    c.integrator.dt = 2e-4;
    c.threads = threads;
    World w(c);
    EXPECT_EQ(w.arena().max_concurrency(), threads);
    for (int s = 0; s < 250; ++s) ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
    EXPECT_GE(w.pair_contacts().size(), 3u) << "a frictional pile";
    hash[threads - 1] = w.state_hash();
  }
  EXPECT_EQ(hash[1], hash[0]);
  EXPECT_EQ(hash[2], hash[0]);
}

}  // namespace
}  // namespace dem
