// Step doubling through the World (control = doubling; docs/physics.md 6; docs/design.md, Time):
//  1. Tolerance means something: the error against a converged reference falls as the tolerance
//     tightens from 1e-2 to 1e-7, and error / tolerance stays within a factor 10 over that range
//     (seed slope, docs/physics.md 8.8 engine variant, with integrator.error_per_unit_step against the
//     exact stepper; and a damped 50-particle cluster falling onto a plane, with error_per_unit_step
//     and integrator.predicted_dashpot); tolerances down to 1e-12 terminate with forced steps counted.
//  2. A particle flying at a wall at v h_max = 10 R spends >= 90% of its steps at level_max, is
//     demoted only near the wall, never tunnels and bounces with the docs/physics.md 2.2 restitution.
//  3. Two islands at different levels that touch inside one round are merged and the round redone;
//     linear momentum is conserved to round-off and the impulse reaches the struck particle.
//  4. Bitwise determinism for 1, 2, 3 and 8 threads and repeated runs, particles raining onto a bed.
//  5. Energy of an undamped dense packing stays within 1e-3 without trend (docs/physics.md 8.6 measure),
//     over an ensemble of packings, and no worse than the fixed step of the coarsest level.
//  6. method = exact under doubling: head-on restitution (docs/physics.md 8.2) and free fall exact.
// Every expected value comes from docs/physics.md formulas, conservation laws or converged references
// computed here; none is copied from the engine's output.
//
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"
#include "tests/test_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

using namespace dem::test;

void run_intervals(World& world, long n) {
  for (long s = 0; s < n; ++s) ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
}

Real max_distance(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  Real worst = 0;
  for (std::size_t q = 0; q < a.size(); ++q) worst = std::max(worst, (a[q] - b[q]).norm());
  return worst;
}

const std::vector<Real> sweep_tolerances{1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7};

struct Sweep {
  std::vector<Real> error;     // per tolerance of sweep_tolerances [m]
  Real reference_refinement;   // the reference against its refinement [m]
};

void print_sweep(const char* scene, const Sweep& s) {
  std::printf("%s: reference vs refined reference %.3e m\n", scene, s.reference_refinement);
  for (std::size_t k = 0; k < sweep_tolerances.size(); ++k)
    std::printf("  tolerance %.0e  error %.3e m  error/tolerance %.3e\n", sweep_tolerances[k], s.error[k],
                s.error[k] / sweep_tolerances[k]);
}

// ---------------------------------------------------------------------------------------------
// 1. Tolerance means something

// docs/physics.md 8.8, engine variant (the parameters of scenes/seed_slope.toml): sphere m = 4, R = 1 on
// the plane z = 0 with gravity 9.8 tilted so tan(theta) = 0.2 down +x; k = 2000, zeta = 0.2, k_t = 2k/7,
// zeta_t = 0.2, mu = 0.7, mu_s = 1, mu_r = 0.4, mu_rs = 0.3, standard rolling mode, start at the
// equilibrium overlap with v = 10 down-slope. dt_base = 2^-10 s; sync interval 2^-5 s (level_max 5).
constexpr Real slope_dt_base = 0x1p-10;
constexpr int slope_level_max = 5;

WorldConfig seed_slope() {
  WorldConfig c;
  c.threads = 1;
  const Real g = 9.8, tan_theta = 0.2, cos_theta = 1 / std::sqrt(1 + tan_theta * tan_theta);
  const Real sin_theta = tan_theta * cos_theta;
  c.model.gravity = Vec3(g * sin_theta, 0, -g * cos_theta);
  c.model.separation = Separation::force_zero;
  c.model.rolling_mode = RollingMode::standard;
  ContactConfig& law = c.contacts[0];
  law.normal_stiffness = 2000;
  law.normal_damping = {DampingKind::damping_ratio, 0.2};
  law.tangential_damping = {DampingKind::damping_ratio, 0.2};
  law.sliding_friction = 0.7;
  law.static_friction = 1.0;
  law.rolling_friction = 0.4;
  law.rolling_static_friction = 0.3;
  c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitZ()));
  const Real m = 4, r = 1, overlap = m * g * cos_theta / law.normal_stiffness;
  c.particles.push_back(particle(Vec3(0, 0, r - overlap), Vec3(10, 0, 0), r, m));
  return c;
}

// Positions at every sync time over the scene's 8 s.
std::vector<Vec3> slope_trajectory(Real tolerance) {
  WorldConfig c = seed_slope();
  set_doubling(c, slope_dt_base, slope_level_max - 28, slope_level_max, tolerance);
  c.integrator.error_per_unit_step = true;
  World world(c);
  const long intervals = std::lround(8.0 / world.sync_interval());
  std::vector<Vec3> path;
  for (long s = 0; s < intervals; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    path.push_back(world.state().position[0]);
  }
  EXPECT_EQ(world.counters().forced_steps, 0u) << "tolerance " << tolerance << ": level_min reached";
  return path;
}

// The same positions from the exact stepper at a fixed step of sync_interval / substeps: an
// independent method, exact between the mode switches it finds as roots (docs/physics.md 5.6, 5.7).
std::vector<Vec3> slope_exact_trajectory(long substeps) {
  WorldConfig c = seed_slope();
  c.integrator.method = Method::exact;
  c.integrator.dt = std::ldexp(slope_dt_base, slope_level_max) / static_cast<Real>(substeps);
  World world(c);
  const long intervals = std::lround(8.0 / std::ldexp(slope_dt_base, slope_level_max));
  std::vector<Vec3> path;
  for (long s = 0; s < intervals; ++s) {
    for (long k = 0; k < substeps; ++k) EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    path.push_back(world.state().position[0]);
  }
  return path;
}

// Reference: the exact stepper at one step per sync interval, checked against eight.
const Sweep& slope_sweep() {
  static const Sweep sweep = [] {
    const std::vector<Vec3> reference = slope_exact_trajectory(1);
    Sweep s;
    s.reference_refinement = max_distance(reference, slope_exact_trajectory(8));
    for (Real tol : sweep_tolerances) s.error.push_back(max_distance(slope_trajectory(tol), reference));
    // The reference is the physics of docs/physics.md 8.8: standard-mode stop distance 19.357 within 0.5%.
    EXPECT_NEAR(reference.back().x(), 19.357, 0.005 * 19.357);
    print_sweep("seed slope (max position error over the 8 s trajectory)", s);
    return s;
  }();
  return sweep;
}

// A frictionless polydisperse cluster of 50 spheres (R 4-5 mm, e = 0.5, k = 1e4) falling onto a
// plane: over 30 ms each particle meets the plane and neighbours a few times, not enough for the
// trajectories to be chaotic-dominated. Sync interval 2^-10 s.
WorldConfig cluster() {
  WorldConfig c;
  c.threads = 1;
  c.model.gravity = Vec3(0, 0, -9.81);
  c.contacts[0].normal_stiffness = 1e4;
  c.contacts[0].normal_damping = {DampingKind::restitution, 0.5};
  c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitZ()));
  const Real spacing = 0.0115;
  std::uint64_t draw = 0;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      for (int l = 0; l < 2; ++l) {
        Real u[7];
        for (Real& x : u) x = uniform(3, draw++);
        ParticleConfig p;
        p.radius = 0.004 + 0.001 * u[0];
        p.position = Vec3(i * spacing + 0.001 * u[1], j * spacing + 0.001 * u[2], 0.0065 + l * spacing + 0.001 * u[3]);
        p.velocity = Vec3(0.4 * (u[4] - 0.5), 0.4 * (u[5] - 0.5), -0.5 + 0.2 * u[6]);
        c.particles.push_back(p);
      }
  return c;
}

constexpr long cluster_intervals = 30;  // of 2^-10 s

std::vector<Vec3> cluster_end(WorldConfig c, long intervals_per_sync) {
  World world(c);
  run_intervals(world, cluster_intervals * intervals_per_sync);
  std::vector<Vec3> end(world.state().size());
  for (std::size_t q = 0; q < end.size(); ++q) end[world.state().id[q]] = world.state().position[q];
  return end;
}

// Error per unit step and the predicted dashpot: with the seed's norm the error falls only as about
// tol^0.4 (velocity errors are weighed by the step), and with the half-step dashpot velocity Verlet
// is first order in these lasting damped contacts, so each decade of tolerance costs ten times the
// steps (1.8 M particle-steps at 1e-3, 159 M at 1e-5) instead of about 2.7 times (0.27 M, 1.9 M).
// Steps down to 2^-38 s: a contact onset (the dashpot force jumps by c v) stays first order in h, and
// with level_min = -18 (2^-28 s) tolerances of 1e-5 and below were forced there.
std::vector<Vec3> cluster_doubling(Real tolerance) {
  WorldConfig c = cluster();
  set_doubling(c, 0x1p-10, -28, 0, tolerance);
  c.integrator.error_per_unit_step = true;
  c.integrator.predicted_dashpot = true;
  return cluster_end(c, 1);
}

// Reference: the exact stepper (docs/physics.md 5.4 scheme D, an independent method: exact for free
// flight, wall contacts and isolated pairs, second order in the coupling) at a fixed step of 2^-22 s,
// checked against 2^-23 s.
std::vector<Vec3> cluster_exact(int exponent) {
  WorldConfig c = cluster();
  c.integrator.method = Method::exact;
  c.integrator.dt = std::ldexp(1.0, -exponent);
  return cluster_end(c, 1L << (exponent - 10));
}

const Sweep& cluster_sweep() {
  static const Sweep sweep = [] {
    const std::vector<Vec3> reference = cluster_exact(22);
    Sweep s;
    s.reference_refinement = max_distance(reference, cluster_exact(23));
    for (Real tol : sweep_tolerances) s.error.push_back(max_distance(cluster_doubling(tol), reference));
    print_sweep("50-particle cluster (max position error over particles at 30 ms)", s);
    return s;
  }();
  return sweep;
}

// The error falls as the tolerance tightens: monotone (a step may repeat the previous error within
// 5% when both tolerances take the same steps through an event), or at least by two orders of
// magnitude over the five decades. The reference is ten times better than the smallest error.
void expect_error_falls(const Sweep& s) {
  ASSERT_EQ(s.error.size(), sweep_tolerances.size());
  EXPECT_LE(s.reference_refinement, 0.1 * *std::min_element(s.error.begin(), s.error.end()));
  bool monotone = true;
  for (std::size_t k = 1; k < s.error.size(); ++k) monotone = monotone && s.error[k] <= 1.05 * s.error[k - 1];
  const Real fall = s.error.front() / s.error.back();
  EXPECT_TRUE(monotone || fall >= 100) << "fall over the range " << fall;
  EXPECT_GE(fall, 10.0);
  ::testing::Test::RecordProperty("error_at_1e-2", sci(s.error.front()));
  ::testing::Test::RecordProperty("error_at_1e-7", sci(s.error.back()));
}

// Tolerance proportionality: max / min of error / tolerance over 1e-2 .. 1e-7 must be below 10.
Real spread_of_error_over_tolerance(const Sweep& s) {
  Real lo = std::numeric_limits<Real>::infinity(), hi = 0;
  for (std::size_t k = 0; k < s.error.size(); ++k) {
    lo = std::min(lo, s.error[k] / sweep_tolerances[k]);
    hi = std::max(hi, s.error[k] / sweep_tolerances[k]);
  }
  ::testing::Test::RecordProperty("spread_of_error_over_tolerance", sci(hi / lo));
  return hi / lo;
}

TEST(Doubling, SeedSlopeErrorFallsAsToleranceTightens) { expect_error_falls(slope_sweep()); }

TEST(Doubling, SeedSlopeErrorIsProportionalToTolerance) {
  EXPECT_LT(spread_of_error_over_tolerance(slope_sweep()), 10.0);
}

// The ball starts sliding on the slope with its friction spring at zero: the friction and its torque
// ramp up within mu N / (k_t v), about 5 ms, and the spin carries what a step makes of that ramp
// through the whole sliding phase. A touching particle's first step is level_min's, so even a loose
// tolerance with steps of up to 0.1 s resolves the ramp (a first step of t_c / 8, 12.5 ms, would
// misjudge it by several times the bound below). Against the exact stepper (an independent method,
// exact between the mode switches it finds as roots) at 0.5 s, mid-slide.
TEST(Doubling, SeedSlopeResolvesTheFrictionRampAtTheStartEvenAtALooseTolerance) {
  const auto spin_at_half_second = [](WorldConfig c) {
    World world(c);
    const long intervals = std::lround(0.5 / world.sync_interval());
    run_intervals(world, intervals);
    EXPECT_NEAR(world.time(), 0.5, 1e-12);
    return world.state().angular_velocity[0].y();
  };
  WorldConfig exact = seed_slope();
  exact.integrator.method = Method::exact;
  exact.integrator.dt = 1e-4;
  const Real reference = spin_at_half_second(exact);
  WorldConfig loose = seed_slope();
  set_doubling(loose, 0.1, -14, 0, 0.1);
  const Real spin = spin_at_half_second(loose);
  std::printf("spin at 0.5 s: exact stepper %.6f rad/s, doubling at tol 0.1 %.6f rad/s\n", reference, spin);
  EXPECT_GT(reference, 3.0);  // sliding: the friction torque spins the ball up at about 7 rad/s^2
  EXPECT_LT(std::abs(spin - reference), 1e-3 * reference);
}

// Which particles start fine (docs/physics.md 6.6): those touching a partner or a wall at the start,
// not the free ones, under both one level per island and a level per particle.
TEST(Doubling, ParticlesTouchingAtTheStartBeginAtLevelMinAndFreeOnesAtLevelZero) {
  for (bool particle_levels : {false, true}) {
    SCOPED_TRACE(particle_levels ? "levels per particle" : "one level per island");
    WorldConfig c;
    c.threads = 1;
    c.contacts[0].normal_stiffness = 1e4;
    c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitZ()));
    const Real r = 0.01;
    c.particles.push_back(particle(Vec3(0, 0, 0.5), Vec3::Zero(), r, 0.01));             // touching the next
    c.particles.push_back(particle(Vec3(1.998 * r, 0, 0.5), Vec3::Zero(), r, 0.01));     // touching the last
    c.particles.push_back(particle(Vec3(1, 0, 0.999 * r), Vec3::Zero(), r, 0.01));       // on the wall
    c.particles.push_back(particle(Vec3(2, 0, 0.5), Vec3(1, 0, 0), r, 0.01));            // free
    set_doubling(c, 1e-4, -6, 3, 1e-2);
    c.integrator.particle_levels = particle_levels;
    World world(c);
    const State& s = world.state();
    for (std::size_t q = 0; q < s.size(); ++q) {
      SCOPED_TRACE(::testing::Message() << "particle " << s.id[q]);
      EXPECT_EQ(s.level[q], s.id[q] == 3 ? 0 : -6);
    }
  }
}

TEST(Doubling, ClusterErrorFallsAsToleranceTightens) { expect_error_falls(cluster_sweep()); }

TEST(Doubling, ClusterErrorIsProportionalToTolerance) {
  EXPECT_LT(spread_of_error_over_tolerance(cluster_sweep()), 10.0);
}

// Below the round-off floor (docs/physics.md 6.6: ~eps |x| / (|dX| + dX_min)) only forced accepts at
// level_min remain. The run must still end, with bounded work: every accepted step covers at least
// one tick, and costs at most 3 trials per level it can drop, plus its own 3.
void expect_terminates_with_forced_steps(WorldConfig c, Real dt_base, int level_min, int level_max, long intervals) {
  set_doubling(c, dt_base, level_min, level_max, 1e-12);
  World world(c);
  run_intervals(world, intervals);
  const RunCounters& k = world.counters();
  EXPECT_GT(k.forced_steps, 0u);
  const std::uint64_t ticks = static_cast<std::uint64_t>(intervals) << (level_max - level_min);
  const std::uint64_t n = world.state().size();
  EXPECT_LE(k.particle_steps, 3 * n * ticks * static_cast<std::uint64_t>(level_max - level_min + 1));
  ::testing::Test::RecordProperty("forced_steps", std::to_string(k.forced_steps));
  std::printf("tolerance 1e-12: forced %llu of %llu accepted particle-steps\n",
              static_cast<unsigned long long>(k.forced_steps), static_cast<unsigned long long>(k.accepted_steps));
}

TEST(Doubling, TolerancesDownTo1e12TerminateWithForcedSteps) {
  {
    SCOPED_TRACE("seed slope, 1 s (slide to roll included)");
    expect_terminates_with_forced_steps(seed_slope(), slope_dt_base, slope_level_max - 10, slope_level_max, 128);
  }
  {
    SCOPED_TRACE("cluster, 8 ms");
    expect_terminates_with_forced_steps(cluster(), 0x1p-10, -10, 0, 8);
  }
}

// ---------------------------------------------------------------------------------------------
// 2. A particle flying at a wall

// R = 1 cm, m = 10 g at v = 10 m/s against the plane x = 0; k = 4e6 N/m (omega0 = 2e4 1/s, contact
// ~1.5e-4 s, about 1/64 of the longest step), zeta = 0.1 with the wall (m* = m). dt_base = h_max =
// 10 R / v = 0.01 s, level_max = 0, level_min = -20, tolerance 1e-6.
struct WallRun {
  std::vector<std::uint64_t> histogram;
  Real restitution;
  Real min_x;            // smallest centre position seen at a sync time [m]
  Real farthest_demoted;  // largest gap to the wall at a sync time with level < level_max [m]
};

constexpr Real wall_r = 0.01, wall_m = 0.01, wall_v = 10, wall_k = 4e6, wall_zeta = 0.1, wall_tol = 1e-6;
constexpr Real wall_h = 10 * wall_r / wall_v;

WorldConfig wall_scene(Real start_gap, Real skin, bool with_bystander = false) {
  WorldConfig c;
  c.threads = 1;
  c.contacts[0].normal_stiffness = wall_k;
  c.contacts[0].normal_damping = {DampingKind::damping_ratio, wall_zeta};
  c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitX()));
  c.particles.push_back(particle(Vec3(wall_r + start_gap, 0, 0), Vec3(-wall_v, 0, 0), wall_r, wall_m));
  // A second particle at rest far from the first: a world of two has candidate pairs to keep, so the
  // skin caps its rounds (a world of one has none).
  if (with_bystander) c.particles.push_back(particle(Vec3(wall_r + start_gap, 1, 0), Vec3::Zero(), wall_r, wall_m));
  set_doubling(c, wall_h, -20, 0, wall_tol);
  c.broadphase.skin = skin;
  return c;
}

// Accepted particle-steps at `level` (the histogram only grows as far as the levels used).
std::uint64_t steps_at(const std::vector<std::uint64_t>& histogram, int level, int level_min) {
  const std::size_t k = static_cast<std::size_t>(level - level_min);
  return k < histogram.size() ? histogram[k] : 0;
}

WallRun fly_at_wall(Real start_gap, long intervals, Real skin, bool with_bystander = false) {
  World world(wall_scene(start_gap, skin, with_bystander));
  WallRun r{{}, 0, std::numeric_limits<Real>::infinity(), 0};
  for (long s = 0; s < intervals; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Real x = world.state().position[0].x();
    r.min_x = std::min(r.min_x, x);
    if (world.state().level[0] < 0) r.farthest_demoted = std::max(r.farthest_demoted, x - wall_r);
  }
  r.histogram = world.counters().level_histogram;
  r.restitution = world.state().velocity[0].x() / wall_v;
  return r;
}

TEST(Doubling, ParticleFlyingAtAWallStaysAtLevelMaxExceptNearItAndBouncesWithTheOracleRestitution) {
  // In a world of more than one particle the skin caps the level: a round may only be as long as
  // keeps 8 (|v| h + |a| h^2 / 2) within the candidate skin, at least 2 R_max (world_doubling.cpp,
  // round_level). With the default skin (0.1 R) that is v h <= R / 4, i.e. level <= -6 here; no step
  // reaches level_max.
  {
    const WallRun capped = fly_at_wall(1000 * wall_r, 50, -1, true);
    std::uint64_t below = 0;
    for (int level = -20; level <= -6; ++level) below += steps_at(capped.histogram, level, -20);
    EXPECT_GT(below, 0u);
    for (int level = -5; level <= 0; ++level) EXPECT_EQ(steps_at(capped.histogram, level, -20), 0u) << "level " << level;
  }
  // Alone, the particle's rounds are not capped: with the default skin it reaches level_max.
  {
    const WallRun alone = fly_at_wall(1000 * wall_r, 50, -1);
    EXPECT_GT(steps_at(alone.histogram, 0, -20), 0u);
  }
  // A lone particle's long rounds widen the candidate skin to cover them; once a second particle
  // joins, rounds are capped again and the skin narrows to what they cover, at most 2 R_max.
  {
    World world(wall_scene(1000 * wall_r, -1));
    run_intervals(world, 5);
    EXPECT_GT(world.candidate_skin(), 10 * wall_r);
    world.add_particle(particle(Vec3(0.5, 1, 0), Vec3::Zero(), wall_r, wall_m));
    run_intervals(world, 1);
    EXPECT_LE(world.candidate_skin(), 2 * wall_r * (1 + 1e-12));
  }
  // So the bounce below runs alone with the default skin, its rounds as long as the sync interval.
  const Real e_oracle = oracle_from_ratio(wall_zeta, Separation::force_zero).restitution;
  const long in_steps = 5000;  // level_max steps to the wall, and as many after
  for (Real phase : {0.3, 0.5371, 0.8123}) {  // not dyadic: different offsets on the fine grid
    SCOPED_TRACE(::testing::Message() << "phase " << phase);
    const WallRun r = fly_at_wall((in_steps + phase) * wall_v * wall_h, 2 * in_steps, -1);
    ASSERT_EQ(r.histogram.size(), 21u);  // level_max was reached
    std::uint64_t total = 0, fine = 0;
    Real allowance = 0;
    for (int level = -20; level < 0; ++level) {
      const std::uint64_t n = r.histogram[level + 20];
      fine += n;
      // Error control bound on the accepted velocity error of one step (formula (3), velocity weight
      // 1, |dX| <= v h since the wall only slows the particle): |dv| <= tol (v h + dx_min R) / h.
      allowance += static_cast<Real>(n) * wall_tol * (1 + 1e-3 * wall_r / (wall_v * std::ldexp(wall_h, level)));
    }
    total = fine + r.histogram[20];
    // >= 90% of the accepted particle-steps at level_max.
    EXPECT_GE(static_cast<Real>(r.histogram[20]), 0.9 * static_cast<Real>(total));
    // The contact was resolved with fine steps: some at least 8 per contact time.
    const Real contact_time = oracle_from_ratio(wall_zeta, Separation::force_zero).time / std::sqrt(wall_k / wall_m);
    std::uint64_t resolving = 0;
    for (int level = -20; std::ldexp(wall_h, level) <= contact_time / 8; ++level) resolving += r.histogram[level + 20];
    EXPECT_GE(resolving, 8u);
    // Demoted only near the wall: approaching, the wall is anticipated within 2 v h_max = 20 R;
    // leaving, promotion is one level per at most two steps, under 2 h_max = another 20 R of flight.
    EXPECT_LE(r.farthest_demoted, 40 * wall_r);
    // Never tunnels: the centre stays on the particles' side, and the particle comes back.
    EXPECT_GT(r.min_x, 0.0);
    EXPECT_GT(r.restitution, 0.0);
    // Restitution of docs/physics.md 2.2 (force-zero, wall m* = m): within the accumulated allowance.
    EXPECT_NEAR(r.restitution, e_oracle, allowance);
    std::printf("wall, phase %.2f: level_max share %.4f (%llu of %llu), e %.8f oracle %.8f (diff %.2e, bound %.2e), "
                "demoted up to %.2f R from the wall; histogram (level: steps):",
                phase, static_cast<Real>(r.histogram[20]) / static_cast<Real>(total),
                static_cast<unsigned long long>(r.histogram[20]), static_cast<unsigned long long>(total), r.restitution,
                e_oracle, r.restitution - e_oracle, allowance, r.farthest_demoted / wall_r);
    for (int level = -20; level <= 0; ++level)
      if (r.histogram[level + 20] > 0)
        std::printf(" %d:%llu", level, static_cast<unsigned long long>(r.histogram[level + 20]));
    std::printf("\n");
  }
}

// ---------------------------------------------------------------------------------------------
// 3. Islands at different levels touching inside one round

// Newton's cradle in free space: C (moving at v) hits A (at rest), A then hits B (at rest, 3 mm
// beyond A). Equal masses, undamped. The prediction underestimates A: at the start of the round in
// which C reaches A, A is at rest without force, so the anticipated closing of A and B is zero and they
// are not linked; B, alone and free, takes the round in one step at level_max, while A and C, linked
// by anticipation, step at fine levels. Within the round A is pushed into B. Only the check after the
// round (gap at the start <= sum of excursions) can catch it: it must merge and redo.
TEST(Doubling, IslandsAtDifferentLevelsThatTouchInARoundAreMergedAndMomentumIsConserved) {
  const Real r = 0.01, m = 0.01, v = 1, gap_ab = 3e-3;
  const Real round = 0x1p-7;  // sync interval = longest step [s]
  WorldConfig c;
  c.threads = 1;
  c.contacts[0].normal_stiffness = 1e4;  // pair contact ~2.2 ms, A's push lasts well inside a round
  // C starts 3 rounds and 1 mm from A: the onset is 1 ms into a round, B is hit ~5 ms into it.
  const Real gap_ca = 3 * v * round + 1e-3;
  c.particles.push_back(particle(Vec3(0, 0, 0), Vec3::Zero(), r, m));                   // A
  c.particles.push_back(particle(Vec3(2 * r + gap_ab, 0, 0), Vec3::Zero(), r, m));      // B
  c.particles.push_back(particle(Vec3(-(2 * r + gap_ca), 0, 0), Vec3(v, 0, 0), r, m));  // C
  set_doubling(c, round, -20, 0, 1e-4);
  c.broadphase.skin = 10 * r;  // 8 v h_max = 6.2 R: the skin does not shorten the rounds
  World world(c);
  const Vec3 p0 = world.linear_momentum();
  ASSERT_NEAR(p0.x(), m * v, 1e-15);
  bool hit = false;
  int level_a = 0, level_b = 0;
  std::uint64_t redos = 0;
  Real worst_momentum = 0;
  for (int s = 0; s < 12; ++s) {
    const State& st = world.state();
    const int la = st.level[st.index_of_id[0]], lb = st.level[st.index_of_id[1]];
    const std::uint64_t before = world.counters().round_redos;
    ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
    worst_momentum = std::max(worst_momentum, (world.linear_momentum() - p0).norm() / p0.norm());
    if (!hit && std::abs(st.velocity[st.index_of_id[1]].x()) > 0) {
      hit = true;
      level_a = la, level_b = lb;
      redos = world.counters().round_redos - before;
    }
  }
  ASSERT_TRUE(hit) << "B never moved: A passed through it";
  // Before the round of the collision, A (with C) was at a finer level than B.
  EXPECT_LT(level_a, level_b);
  EXPECT_EQ(level_b, 0);
  // The round in which B was struck was redone with the islands merged.
  EXPECT_GE(redos, 1u);
  // Momentum to round-off through the collisions.
  EXPECT_LE(worst_momentum, 1e-14);
  // Newton's cradle: B leaves with C's velocity, A and C stop (elastic, equal masses; 1% covers the
  // controlled Verlet error of the three contacts at tolerance 1e-4).
  const State& st = world.state();
  EXPECT_NEAR(st.velocity[st.index_of_id[1]].x(), v, 1e-2 * v);
  EXPECT_NEAR(st.velocity[st.index_of_id[0]].x(), 0, 1e-2 * v);
  EXPECT_NEAR(st.velocity[st.index_of_id[2]].x(), 0, 1e-2 * v);
  std::printf("islands: levels before the collision round A %d, B %d; redos in it %llu; |dP|/|P| %.2e; "
              "v_B / v_C %.8f\n",
              level_a, level_b, static_cast<unsigned long long>(redos), worst_momentum,
              st.velocity[st.index_of_id[1]].x() / v);
}

// ---------------------------------------------------------------------------------------------
// 4. Determinism under doubling

// A bed of 50 polydisperse spheres with friction and rolling resistance, settled under the fixed
// control in a box, then 25 more rain onto it from 3-6 cm. Settled once, shared by every run.
WorldConfig rain_on_bed(int threads) {
  WorldConfig c = falling_box_scene(5, 5, 2, 11);
  c.threads = 1;
  c.walls[0].half_extents = Vec3(0.028, 0.028, 0.1);
  c.walls[0].point = Vec3(0, 0, 0.1);
  for (ParticleConfig& p : c.particles) {
    p.position += Vec3(-0.026, -0.026, 0);
    p.velocity *= 0.2;
  }
  static const std::vector<ParticleConfig> bed = [&c] {
    World settle(c);
    for (int s = 0; s < 15000; ++s) EXPECT_EQ(settle.advance_sync_interval(), StepStatus::ok);
    std::vector<ParticleConfig> out;
    const State& st = settle.state();
    for (std::size_t q = 0; q < st.size(); ++q) {
      ParticleConfig p = c.particles[st.id[q]];
      p.position = st.position[q];
      p.velocity = st.velocity[q];
      p.angular_velocity = st.angular_velocity[q];
      out.push_back(p);
    }
    return out;
  }();
  c.particles = bed;
  std::uint64_t draw = 0;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) {
      Real u[6];
      for (Real& x : u) x = uniform(99, draw++);
      ParticleConfig p;
      p.radius = 0.004 + 0.001 * u[0];
      p.position = Vec3(-0.022 + i * 0.011 + 0.001 * u[1], -0.022 + j * 0.011 + 0.001 * u[2], 0.03 + 0.03 * u[3]);
      p.velocity = Vec3(0.2 * (u[4] - 0.5), 0.2 * (u[5] - 0.5), -0.3);
      c.particles.push_back(p);
    }
  c.threads = threads;
  set_doubling(c, 2e-5, -4, 5, 1e-2);
  return c;
}

struct RainRun {
  std::uint64_t hash;
  RunCounters counters;
  std::size_t created, removed;  // contacts at the end not there half way, and the reverse
  int widest_level_spread;       // largest (max - min) of state().level at a sync time
  std::size_t threads_seen;
  int arena_concurrency;
};

RainRun rain(int threads) {
  World world(rain_on_bed(threads));
  ThreadRecorder recorder(world.arena());
  constexpr int intervals = 150;  // of 0.64 ms: the rain lands and bounces
  RainRun r{};
  std::vector<std::uint64_t> halfway;
  for (int s = 0; s < intervals; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    if (s == intervals / 2) halfway = world.pair_contacts().key;
    const auto [lo, hi] = std::minmax_element(world.state().level.begin(), world.state().level.end());
    r.widest_level_spread = std::max(r.widest_level_spread, *hi - *lo);
  }
  const std::vector<std::uint64_t>& end = world.pair_contacts().key;
  std::vector<std::uint64_t> only_end, only_half;
  std::set_difference(end.begin(), end.end(), halfway.begin(), halfway.end(), std::back_inserter(only_end));
  std::set_difference(halfway.begin(), halfway.end(), end.begin(), end.end(), std::back_inserter(only_half));
  r.hash = world.state_hash();
  r.counters = world.counters();
  r.created = only_end.size();
  r.removed = only_half.size();
  r.threads_seen = recorder.distinct();
  r.arena_concurrency = world.arena().max_concurrency();
  return r;
}

TEST(Doubling, SameHashForOneTwoThreeAndEightThreadsAndRepeatedRuns) {
  const AllowThreads allow_eight(8);
  const RainRun one = rain(1);
  // The run exercises what doubling adds: mixed levels, contacts made and broken, candidate
  // rebuilds, and rounds redone.
  std::size_t levels_used = 0;
  for (std::uint64_t n : one.counters.level_histogram) levels_used += n > 0;
  EXPECT_GE(levels_used, 3u);
  EXPECT_GE(one.widest_level_spread, 2);
  EXPECT_GT(one.created, 0u);
  EXPECT_GT(one.removed, 0u);
  EXPECT_GE(one.counters.pair_rebuilds, 3u);
  EXPECT_GT(one.counters.round_redos, 0u);
  for (int threads : {2, 3, 8}) {
    const RainRun r = rain(threads);
    EXPECT_EQ(r.hash, one.hash) << threads << " threads";
    EXPECT_EQ(r.counters.accepted_steps, one.counters.accepted_steps) << threads << " threads";
    EXPECT_EQ(r.arena_concurrency, threads);
    if (threads == 8) {
      EXPECT_GE(r.threads_seen, 2u) << "at least two threads must have done work";
    }
  }
  EXPECT_EQ(rain(2).hash, one.hash) << "repeated run";
  std::printf("rain: levels used %zu, widest spread %d, contacts created %zu removed %zu, rebuilds %llu, redos %llu\n",
              levels_used, one.widest_level_spread, one.created, one.removed,
              static_cast<unsigned long long>(one.counters.pair_rebuilds),
              static_cast<unsigned long long>(one.counters.round_redos));
}

// ---------------------------------------------------------------------------------------------
// 5. Energy of an undamped dense packing

TEST(Doubling, UndampedPackingEnergyErrorIsBoundedWithoutTrend) {
  // docs/physics.md 8.6 measure: |dE| <= 1e-3 of the initial kinetic + elastic energy, no trend. Eight
  // packings that differ in their random draws, 2e4 sync intervals each, under doubling at the default
  // tolerance with level_max at omega_max h = 0.3.
  const PackingEnsemble e = packing_ensemble(1e-2, 20'000, 8);
  EXPECT_LE(e.max_error, 1e-3);
  // Each contact event leaves an error of random sign, so one run wanders; one run's last tenth
  // against its first says little (under doubling the first tenth's error is ~1e-5 and one event
  // can leave 2e-4). Across runs a trend shows as a mean away from zero or an RMS growing in
  // proportion to time: from the 2nd tenth to the 10th, 5 times for a drift, sqrt(5) = 2.2 for a
  // random walk, 1 for a bounded oscillation. Bounds: the mean within 3 standard errors of zero; the
  // growth at most 1.5 sqrt(5) (the RMS of 8 runs is known to about 25%).
  EXPECT_LE(std::abs(e.end_mean), 3 * e.end_standard_error);
  EXPECT_LE(e.rms.back(), 1.5 * std::sqrt(5.0) * e.rms[1]);
  // And the variable step is no worse than the fixed step of its coarsest level on the same packings.
  const PackingEnsemble fixed = packing_ensemble(1e-2, 20'000, 8, true);
  EXPECT_LE(e.rms.back(), fixed.rms.back());
}

// ---------------------------------------------------------------------------------------------
// 6. method = exact under doubling

TEST(Doubling, ExactMethodHeadOnPairMatchesTheOracleRestitution) {
  // docs/physics.md 8.2: m = 1 kg each, k = 1e5 N/m; zeta = 0.1 (e = 0.74408 force-zero, 0.72925 overlap)
  // and undamped (e = 1). The exact stepper is exact for an isolated pair at any step.
  const Real radius = 0.05, gap = 1e-3, v = 0.5;
  for (Separation sep : {Separation::force_zero, Separation::overlap}) {
    for (Real zeta : {0.1, 0.0}) {
      const Real e = oracle_from_ratio(zeta, sep).restitution;
      for (int level_max : {-2, 2, 5}) {  // sync interval 0.25 ms .. 32 ms, t_c ~ 7 ms
        SCOPED_TRACE(::testing::Message() << "separation " << static_cast<int>(sep) << " zeta " << zeta
                                          << " level_max " << level_max);
        WorldConfig c;
        c.threads = 1;
        c.model.separation = sep;
        c.integrator.method = Method::exact;
        c.contacts[0].normal_stiffness = 1e5;
        c.contacts[0].normal_damping = {DampingKind::damping_ratio, zeta};
        c.particles = {particle(Vec3(-radius - 0.5 * gap, 0, 0), Vec3(v, 0, 0), radius, 1),
                       particle(Vec3(radius + 0.5 * gap, 0, 0), Vec3(-v, 0, 0), radius, 1)};
        set_doubling(c, 1e-3, -8, level_max, 1e-6);
        World world(c);
        ASSERT_EQ(world.run_until(0.1), StepStatus::ok);  // onset at 1 ms, released by 9 ms
        const State& s = world.state();
        const Real v_out = s.velocity[s.index_of_id[1]].x() - s.velocity[s.index_of_id[0]].x();
        EXPECT_NEAR(v_out / (2 * v), e, 1e-9);
        EXPECT_NEAR(world.linear_momentum().x(), 0.0, 1e-15);
      }
    }
  }
}

TEST(Doubling, FreeFallIsExactUnderDoublingWithBothMethods) {
  // docs/physics.md 8.1: exact at any step; only round-off, growing at most ~ n eps |x| over n steps.
  const Vec3 g(0.3, -0.2, -9.81), x0(0.1, -2.0, 50.0), v0(1.5, 2.0, 3.0);
  for (Method method : {Method::verlet, Method::exact}) {
    SCOPED_TRACE(method == Method::exact ? "exact" : "verlet");
    WorldConfig c;
    c.threads = 1;
    c.model.gravity = g;
    c.integrator.method = method;
    c.particles.push_back(particle(x0, v0, 0.1, 2.0));
    set_doubling(c, 1e-3, -10, 4, 1e-6);
    c.broadphase.skin = 100;  // 8 x the reach of a round stays inside it: rounds at level_max
    World world(c);
    const long n = 500;
    const Real eps = std::numeric_limits<Real>::epsilon();
    for (long s = 1; s <= n; ++s) {
      ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
      const Real t = world.time();
      const Vec3 x = x0 + v0 * t + 0.5 * g * t * t, v = v0 + g * t;
      const Real x_scale = x0.norm() + v0.norm() * t + 0.5 * g.norm() * t * t, v_scale = v0.norm() + g.norm() * t;
      ASSERT_LE((world.state().position[0] - x).norm(), 4.0 * static_cast<Real>(s) * eps * x_scale) << "interval " << s;
      ASSERT_LE((world.state().velocity[0] - v).norm(), 4.0 * static_cast<Real>(s) * eps * v_scale) << "interval " << s;
    }
    EXPECT_EQ(world.counters().level_histogram.back(), static_cast<std::uint64_t>(n)) << "free flight at level_max";
  }
}

}  // namespace
}  // namespace dem
