// Levels per particle inside one touching group (engine/multilevel_stepper.h; docs/design.md, Time):
//  1. Every particle at one level is velocity Verlet: the World's fixed-step run of the same scene
//     (friction, rolling resistance, a box, contacts forming and ending) agrees to round-off.
//  2. Three levels in one touching group: linear momentum is conserved to round-off, whatever the
//     levels and as they change hands, while the contacts change every velocity.
//  3. A coarse particle held only by a finer one (a heavy ball on a light one on a floor) converges
//     at second order to the all-fine reference as every step halves.
//  4. Angular momentum about a fixed point across levels: its error shrinks as the steps halve.
//  5. A group reset after stepping another one steps bit for bit as a group made fresh.
//  6. Particles that replay the paths another group recorded for them leave their integrated partners'
//     steps, contacts and impulses bit for bit as that group made them.
//  7. Each contact's impulse, first moment and angular impulse over an advance add up, per particle,
//     to its change of momentum, of position beyond its start velocity, and of spin.
// Expected values come from conservation laws, from runs of the same physics at one level (the
// World's fixed step, or this stepper at a converged step) and from a fresh group; none is copied from
// this stepper's output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "engine/multilevel_stepper.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

/// Every pair of an n-particle group as candidates: no skin to outrun.
broadphase::CandidatePairs all_pairs(std::size_t n) {
  broadphase::CandidatePairs c;
  c.row_start.assign(1, 0);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b) c.partner.push_back(static_cast<std::uint32_t>(b));
    c.row_start.push_back(static_cast<std::uint32_t>(c.partner.size()));
  }
  return c;
}

MultilevelPhysics physics_of(const World& world, Real dt_base, int level_min) {
  const WorldConfig& c = world.config();
  const MaterialTable& m = world.materials();
  MultilevelPhysics p;
  p.materials = &m;
  const RollingKind rolling = !m.any_rolling()                            ? RollingKind::none
                              : c.model.rolling_mode == RollingMode::seed ? RollingKind::seed
                                                                          : RollingKind::standard;
  p.kernels = select_force_kernels(c.model.separation, m.any_friction(), rolling);
  p.gravity = c.model.gravity;
  p.dimension = c.model.dimension;
  p.dt_base = dt_base;
  p.level_min = level_min;
  return p;
}

/// `walls`: a copy of the World's, which the group sets to its times.
MultilevelGroup group_of(const World& world, Walls& walls, Real dt_base, int level_min, const std::vector<int>& levels) {
  return MultilevelGroup(world.state(), all_pairs(world.state().size()), walls,
                         physics_of(world, dt_base, level_min), world.time(), levels);
}

Vec3 linear_momentum(const State& s) {
  Vec3 p = Vec3::Zero();
  for (std::size_t q = 0; q < s.size(); ++q) p += s.velocity[q] / s.inv_mass[q];
  return p;
}

Real momentum_scale(const State& s) {
  Real sum = 0;
  for (std::size_t q = 0; q < s.size(); ++q) sum += s.velocity[q].norm() / s.inv_mass[q];
  return sum;
}

Vec3 angular_momentum(const State& s) {
  Vec3 l = Vec3::Zero();
  for (std::size_t q = 0; q < s.size(); ++q)
    l += s.position[q].cross(s.velocity[q]) / s.inv_mass[q] + s.angular_velocity[q] / s.inv_inertia[q];
  return l;
}

TEST(MultilevelStepper, EveryParticleAtOneLevelIsVelocityVerlet) {
  WorldConfig c = falling_box_scene(3, 3, 3, 7);
  c.threads = 1;
  const Real dt = c.integrator.dt;
  World world(c);
  Walls walls = world.walls();
  // Level 0 of a scale whose finest level is -2: ticks of dt / 4, steps of four ticks.
  MultilevelGroup group = group_of(world, walls, dt, -2, std::vector<int>(world.state().size(), 0));
  const int rounds = 40, steps_per_round = 10;
  std::size_t most_contacts = 0;
  for (int r = 0; r < rounds; ++r) {
    advance(world, steps_per_round);
    group.advance(4 * steps_per_round);
    most_contacts = std::max(most_contacts, world.pair_contacts().size());
    ASSERT_EQ(group.pair_contacts().size(), world.pair_contacts().size()) << "round " << r;
  }
  ASSERT_GT(most_contacts, 3u);  // the scene has contacts to get right
  const State& a = world.state();
  const State& b = group.state();
  Real dx = 0, dv = 0, dw = 0, v_max = 0;
  for (std::size_t q = 0; q < a.size(); ++q) {
    dx = std::max(dx, (a.position[q] - b.position[q]).norm());
    dv = std::max(dv, (a.velocity[q] - b.velocity[q]).norm());
    dw = std::max(dw, (a.angular_velocity[q] - b.angular_velocity[q]).norm() * a.radius[q]);
    v_max = std::max(v_max, a.velocity[q].norm());
  }
  std::printf("one level against the World: |dx| %.3e m, |dv| %.3e m/s, R|dw| %.3e m/s (v_max %.3f m/s)\n", dx, dv,
              dw, v_max);
  // Round-off only: a wrong weight or moment would err by about a step's change, h v ~ 1e-5 m.
  EXPECT_LT(dx, 1e-12);
  EXPECT_LT(dv, 1e-9 * v_max);
  EXPECT_LT(dw, 1e-9 * v_max);
  EXPECT_EQ(group.particle_steps(), a.size() * rounds * steps_per_round);
}

/// Three spheres in a row, pressed together and spinning, in zero gravity, with friction and rolling
/// resistance.
WorldConfig three_in_a_row() {
  WorldConfig c = base_config(1e-5);
  ContactConfig contact;
  contact.normal_stiffness = 2e4;
  contact.normal_damping = {DampingKind::restitution, 0.7};
  contact.tangential_damping = {DampingKind::damping_ratio, 0.2};
  contact.sliding_friction = 0.4;
  contact.rolling_friction = 0.05;
  c.contacts = {contact};
  c.particles = {particle(Vec3(0, 0, 0), Vec3(0.3, 0.05, -0.02), 0.004, 2e-3),
                 particle(Vec3(0.0095, 0.0004, 0), Vec3(0, 0.1, 0.03), 0.006, 8e-3),
                 particle(Vec3(0.0215, -0.0005, 0.0003), Vec3(-0.2, -0.04, 0), 0.0065, 30e-3)};
  c.particles[0].angular_velocity = Vec3(0, 0, 40);
  c.particles[2].angular_velocity = Vec3(10, 0, -20);
  return c;
}

TEST(MultilevelStepper, ThreeLevelsInOneTouchingGroupConserveLinearMomentum) {
  World world(three_in_a_row());
  Walls walls = world.walls();
  const State start = world.state();
  // Finest for the lightest, coarsest for the heaviest; the middle one is coarse to the first and
  // fine to the third.
  MultilevelGroup group = group_of(world, walls, 1e-5, -2, {-2, -1, 0});
  Real worst = 0;
  std::size_t most_contacts = 0;
  const std::vector<std::vector<int>> turns{{-2, -1, 0}, {0, -2, -1}, {-1, 0, -2}};
  for (int r = 0; r < 300; ++r) {
    // Every 50 rounds the levels change hands: the contacts move between lists with their history.
    if (r % 50 == 0) {
      const PairContacts before = group.pair_contacts();
      group.set_levels(turns[(r / 50) % 3]);
      const PairContacts after = group.pair_contacts();
      ASSERT_EQ(after.key, before.key);
      for (std::size_t k = 0; k < before.size(); ++k) {
        EXPECT_EQ(after.tangential_spring[k], before.tangential_spring[k]);
        EXPECT_EQ(after.rolling_spring[k], before.rolling_spring[k]);
        EXPECT_EQ(after.rolling_torque[k], before.rolling_torque[k]);
        EXPECT_EQ(after.force[k], before.force[k]);
      }
    }
    group.advance(8);
    const Vec3 dp = linear_momentum(group.state()) - linear_momentum(start);
    worst = std::max(worst, dp.norm() / momentum_scale(start));
    most_contacts = std::max(most_contacts, group.pair_contacts().size());
  }
  Real change = 0;
  for (std::size_t q = 0; q < start.size(); ++q)
    change = std::max(change, (group.state().velocity[q] - start.velocity[q]).norm());
  std::printf("three levels: largest |dP| / sum m|v| %.3e; contacts at once up to %zu; largest |dv| %.3f m/s\n",
              worst, most_contacts, change);
  ASSERT_EQ(most_contacts, 2u);  // both contacts formed: one touching group across three levels
  EXPECT_GT(change, 0.05);       // and they changed the motion
  EXPECT_LT(worst, 1e-14);
}

/// A heavy ball resting on a light one on a floor, both compressed to 0.8 of their static overlap,
/// released at rest: the heavy one rides on the light one's contact at the light one's level.
/// `damping`: the contacts' damping ratio.
WorldConfig heavy_on_light(Real dt, Real damping) {
  WorldConfig c = base_config(dt);
  c.model.gravity = Vec3(0, 0, -9.81);
  ContactConfig contact;
  contact.normal_stiffness = 1e4;
  contact.normal_damping = {DampingKind::damping_ratio, damping};
  contact.sliding_friction = 0;
  c.contacts = {contact};
  const Real small_r = 0.005, small_m = 1e-3, big_r = 0.02, big_m = 0.5, g = 9.81, k = 1e4;
  const Real bottom = 0.8 * (big_m + small_m) * g / k, top = 0.8 * big_m * g / k;
  const Real z_small = small_r - bottom;
  const Real z_big = z_small + small_r + big_r - top;
  c.particles = {particle(Vec3(0, 0, z_small), Vec3::Zero(), small_r, small_m),
                 particle(Vec3(0, 0, z_big), Vec3::Zero(), big_r, big_m)};
  c.walls = {plane(Vec3::Zero(), Vec3(0, 0, 1))};
  return c;
}

// A scratch group reset to another group (fewer particles, other levels, a wall, other contact
// laws) after it stepped a first one advances exactly as a group made fresh from the same state and
// contacts: nothing of the first survives the reset.
TEST(MultilevelStepper, AResetGroupStepsExactlyAsAFreshOne) {
  World first(three_in_a_row());
  Walls first_walls = first.walls();
  MultilevelGroup reused = group_of(first, first_walls, 1e-5, -2, {-2, -1, 0});
  reused.advance(400);
  ASSERT_GT(reused.pair_contacts().size(), 0u);

  WorldConfig config = heavy_on_light(1e-4, 0.2);
  config.contacts[0].sliding_friction = 0.5;      // springs that remember
  config.particles[1].velocity = Vec3(0.02, 0, 0);  // and slip to wind them
  World second(config);
  Walls source_walls = second.walls();
  MultilevelPhysics physics = physics_of(second, 1e-4, -3);
  physics.wall_margin = 1e-3;  // through wall lists
  MultilevelGroup source(second.state(), all_pairs(2), source_walls, physics, second.time(), {-3, 0});
  source.advance(64);  // contacts with history and forces, levels -3 and 0
  const std::vector<int> levels{-3, -2};
  Walls fresh_walls = second.walls(), reused_walls = second.walls();
  MultilevelGroup fresh(source.state(), all_pairs(2), fresh_walls, physics, source.time(), levels,
                        source.pair_contacts(), source.wall_contacts());
  reused.reset(source.state(), all_pairs(2), reused_walls, physics, source.time(), levels, source.pair_contacts(),
               source.wall_contacts());
  for (int r = 0; r < 20; ++r) {
    fresh.advance(32);
    reused.advance(32);
  }
  ASSERT_EQ(fresh.wall_contacts().size(), 1u);
  ASSERT_EQ(fresh.pair_contacts().size(), 1u);
  for (std::size_t q = 0; q < 2; ++q) {
    EXPECT_EQ(reused.state().position[q], fresh.state().position[q]);
    EXPECT_EQ(reused.state().velocity[q], fresh.state().velocity[q]);
  }
  EXPECT_EQ(reused.pair_contacts().force, fresh.pair_contacts().force);
  EXPECT_EQ(reused.wall_contacts().force, fresh.wall_contacts().force);
  EXPECT_EQ(reused.particle_steps(), fresh.particle_steps());
  EXPECT_EQ(reused.ended_dissipation(), fresh.ended_dissipation());
  EXPECT_EQ(reused.prediction_miss(), fresh.prediction_miss());
  EXPECT_EQ(reused.excursion(), fresh.excursion());
}

/// The heavy ball's height after `duration` [s] with the light one at level -3 and the heavy one at
/// `heavy_level`, dt_base given.
Real heavy_height(Real dt_base, int heavy_level, Real duration, Real damping = 0) {
  World world(heavy_on_light(dt_base, damping));
  Walls walls = world.walls();
  MultilevelGroup group = group_of(world, walls, dt_base, -3, {-3, heavy_level});
  const std::int64_t ticks = std::llround(duration / std::ldexp(dt_base, -3));
  const std::int64_t round = std::int64_t{1} << (heavy_level + 3);
  for (std::int64_t t = 0; t < ticks; t += round) group.advance(round);
  EXPECT_EQ(group.pair_contacts().size(), 1u);  // never parted
  return group.state().position[1].z();
}

TEST(MultilevelStepper, ACoarseParticleHeldByAFinerOneConvergesAtSecondOrder) {
  const Real duration = 0.02;  // a third of the heavy ball's period on its two springs
  // The reference: every particle at the finest level of the finest run, then once more halved.
  const Real reference = heavy_height(2.5e-5 / 16, -3, duration);
  const Real refined = heavy_height(2.5e-5 / 32, -3, duration);
  // At larger steps the coarse side's error and the fine side's partly cancel: the order is judged
  // where it has settled.
  std::vector<Real> error;
  for (Real dt_base : {1e-4, 5e-5, 2.5e-5}) error.push_back(std::abs(heavy_height(dt_base, 0, duration) - reference));
  const Real all_fine = std::abs(heavy_height(2.5e-5, -3, duration) - reference);
  std::printf("heavy on light: reference vs refined %.3e m; errors %.3e %.3e %.3e m (all at the fine level: %.3e "
              "m); orders %.2f %.2f\n",
              std::abs(reference - refined), error[0], error[1], error[2], all_fine, std::log2(error[0] / error[1]),
              std::log2(error[1] / error[2]));
  EXPECT_LT(std::abs(reference - refined), 0.1 * error[2]);  // the reference is converged enough
  EXPECT_GT(std::log2(error[0] / error[1]), 1.7);
  EXPECT_GT(std::log2(error[1] / error[2]), 1.7);
  // Eight times the step for the heavy ball costs little accuracy: its prediction is good.
  EXPECT_LT(error[2], 2 * all_fine);
}

TEST(MultilevelStepper, ADampedContactAcrossLevelsErrsAboutAsMuchAsAllAtTheFinerLevel) {
  // The dashpot reads the heavy ball's velocity from its prediction; Verlet's dashpot lags by h / 2,
  // so a lasting damped contact converges at first order, at one level or several.
  const Real duration = 0.02, zeta = 0.1;
  const Real reference = heavy_height(2.5e-5 / 16, -3, duration, zeta);
  const Real refined = heavy_height(2.5e-5 / 32, -3, duration, zeta);
  Real mixed[2], all_fine[2];
  const Real dt_base[2] = {5e-5, 2.5e-5};
  for (int k = 0; k < 2; ++k) {
    mixed[k] = std::abs(heavy_height(dt_base[k], 0, duration, zeta) - reference);
    all_fine[k] = std::abs(heavy_height(dt_base[k], -3, duration, zeta) - reference);
  }
  std::printf("damped heavy on light: reference vs refined %.3e m; mixed %.3e %.3e m, all fine %.3e %.3e m\n",
              std::abs(reference - refined), mixed[0], mixed[1], all_fine[0], all_fine[1]);
  EXPECT_LT(std::abs(reference - refined), 0.1 * all_fine[1]);
  EXPECT_LT(mixed[1], 0.6 * mixed[0]);  // converges
  for (int k = 0; k < 2; ++k) EXPECT_LT(mixed[k], 2 * all_fine[k]);
}

TEST(MultilevelStepper, AngularMomentumAcrossLevelsConvergesAsTheStepsHalve) {
  std::vector<Real> drift;
  for (Real dt_base : {2e-5, 1e-5, 5e-6}) {
    WorldConfig c = three_in_a_row();
    c.integrator.dt = dt_base;
    World world(c);
    Walls walls = world.walls();
    const Vec3 l0 = angular_momentum(world.state());
    MultilevelGroup group = group_of(world, walls, dt_base, -2, {-2, -1, 0});
    const std::int64_t rounds = std::llround(0.012 / dt_base);
    for (std::int64_t r = 0; r < rounds; ++r) group.advance(4);
    drift.push_back((angular_momentum(group.state()) - l0).norm() / l0.norm());
  }
  std::printf("angular momentum across levels: |dL| / |L| %.3e %.3e %.3e\n", drift[0], drift[1], drift[2]);
  EXPECT_LT(drift[1], 0.35 * drift[0]);  // second order: a quarter per halving
  EXPECT_LT(drift[2], 0.35 * drift[1]);
  EXPECT_LT(drift[0], 1e-2);
}

/// The falling box of 27 spheres at levels -2, -1 and 0 by turns, after 0.4 s of falling and settling
/// in a group of its own: `group` holds it there, `pairs` and `wall_contacts` its contacts then.
struct SettledBox {
  World world{falling_box_scene(3, 3, 3, 7)};
  Walls walls = world.walls();
  std::vector<int> levels;
  MultilevelGroup group;
  State start;
  PairContacts pairs;
  WallContacts wall_contacts;
  Real time = 0;
  SettledBox() {
    for (std::size_t q = 0; q < world.state().size(); ++q) levels.push_back(static_cast<int>(q % 3) - 2);
    group = group_of(world, walls, 1e-4, -2, levels);
    for (int r = 0; r < 4000; ++r) group.advance(4);
    start = group.state();
    pairs = group.pair_contacts();
    wall_contacts = group.wall_contacts();
    time = group.time();
  }
};

TEST(MultilevelStepper, PartnersReplayingTheirPathsLeaveTheIntegratedParticlesStepsBitForBit) {
  SettledBox box;
  const std::size_t n = box.start.size();
  const std::int64_t ticks = 16;
  box.group.advance(ticks);
  const MultilevelGroup& first = box.group;
  // Every other particle replays its path; their contacts with each other are left out.
  const auto replays = [](std::size_t q) { return q % 2 == 1; };
  std::vector<ReplayedPath> replayed(n);
  for (std::size_t q = 0; q < n; ++q) {
    if (!replays(q)) continue;
    replayed[q].steps = first.step_records().data() + first.record_start(q);
    replayed[q].end_position = first.state().position[q];
    replayed[q].end_velocity = first.state().velocity[q];
    replayed[q].end_spin = first.state().angular_velocity[q];
  }
  broadphase::CandidatePairs candidates;
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = a + 1; b < n; ++b)
      if (!replays(a) || !replays(b)) candidates.partner.push_back(static_cast<std::uint32_t>(b));
    candidates.row_start.push_back(static_cast<std::uint32_t>(candidates.partner.size()));
  }
  PairContacts pairs;
  pairs.parts = box.pairs.parts;
  for (std::size_t k = 0; k < box.pairs.size(); ++k) {
    if (replays(box.pairs.i[k]) && replays(box.pairs.j[k])) continue;
    pairs.resize(pairs.size() + 1);
    copy_pair(box.pairs, k, pairs, pairs.size() - 1);
  }
  pairs.index_rows(n);
  WallContacts wall_contacts;
  for (std::size_t k = 0; k < box.wall_contacts.size(); ++k) {
    if (replays(box.wall_contacts.particle[k])) continue;
    wall_contacts.resize(wall_contacts.size() + 1);
    copy_wall(box.wall_contacts, k, wall_contacts, wall_contacts.size() - 1);
  }
  Walls walls = box.world.walls();
  MultilevelGroup again;
  again.reset(box.start, candidates, walls, physics_of(box.world, 1e-4, -2), box.time, box.levels, pairs,
              wall_contacts, &replayed);
  again.advance(ticks);

  std::uint64_t integrated_steps = 0;
  for (std::size_t q = 0; q < n; ++q) {
    EXPECT_EQ(again.state().position[q], first.state().position[q]) << q;
    EXPECT_EQ(again.state().velocity[q], first.state().velocity[q]) << q;
    EXPECT_EQ(again.state().angular_velocity[q], first.state().angular_velocity[q]) << q;
    if (!replays(q)) integrated_steps += static_cast<std::uint64_t>(ticks >> (box.levels[q] + 2));
  }
  EXPECT_EQ(again.particle_steps(), integrated_steps);
  // The contacts between an integrated particle and a replayed one gave the same impulses.
  std::size_t across = 0;
  for (const ContactImpulse& c : again.contact_impulses()) {
    const auto same = std::find_if(first.contact_impulses().begin(), first.contact_impulses().end(),
                                   [&](const ContactImpulse& f) { return f.i == c.i && f.j == c.j; });
    ASSERT_NE(same, first.contact_impulses().end());
    EXPECT_EQ(c.impulse, same->impulse);
    EXPECT_EQ(c.moment, same->moment);
    EXPECT_EQ(c.angular_i, same->angular_i);
    EXPECT_EQ(c.angular_j, same->angular_j);
    across += replays(c.i) != replays(c.j);
  }
  std::printf("replayed partners: %zu contacts across integrated and replayed particles\n", across);
  EXPECT_GT(across, 5u);  // the replayed paths were felt
}

TEST(MultilevelStepper, ContactImpulsesAddUpToEachParticlesChangeOfMotion) {
  World world(three_in_a_row());
  Walls walls = world.walls();
  MultilevelGroup group = group_of(world, walls, 1e-5, -2, {-2, -1, 0});
  const State before = group.state();  // pressed together: both contacts act from the start
  const std::int64_t ticks = 64;
  const Real duration = static_cast<Real>(ticks) * std::ldexp(1e-5, -2);
  group.advance(ticks);
  const State& after = group.state();
  std::vector<Vec3> impulse(3, Vec3::Zero()), moment(3, Vec3::Zero()), angular(3, Vec3::Zero());
  for (const ContactImpulse& c : group.contact_impulses()) {
    impulse[c.i] += c.impulse, impulse[c.j] -= c.impulse;
    moment[c.i] += c.moment, moment[c.j] -= c.moment;
    angular[c.i] += c.angular_i, angular[c.j] += c.angular_j;
  }
  ASSERT_EQ(group.contact_impulses().size(), 2u);
  for (std::size_t q = 0; q < 3; ++q) {
    const Real m = 1 / before.inv_mass[q], inertia = 1 / before.inv_inertia[q];
    const Vec3 dp = m * (after.velocity[q] - before.velocity[q]);
    const Vec3 dx = m * (after.position[q] - before.position[q] - duration * before.velocity[q]);
    const Vec3 dl = inertia * (after.angular_velocity[q] - before.angular_velocity[q]);
    std::printf("particle %zu: |J| %.3e, |J - m dv| %.3e; |K| %.3e, |K - m dx| %.3e; |L| %.3e, |L - I dw| %.3e\n", q,
                impulse[q].norm(), (impulse[q] - dp).norm(), moment[q].norm(), (moment[q] - dx).norm(),
                angular[q].norm(), (angular[q] - dl).norm());
    // A weight or moment arm off by one substep would miss by about |J| h / T, 1/64 here.
    EXPECT_GT(impulse[q].norm(), 0);
    EXPECT_LT((impulse[q] - dp).norm(), 1e-9 * impulse[q].norm());
    EXPECT_LT((moment[q] - dx).norm(), 1e-9 * moment[q].norm());
    EXPECT_LT((angular[q] - dl).norm(), 1e-9 * angular[q].norm());
  }
}

}  // namespace
}  // namespace dem
