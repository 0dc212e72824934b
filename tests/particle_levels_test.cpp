// Step doubling with a level per particle (integrator.particle_levels; engine/particle_level_doubling.h,
// docs/physics.md 6.10), through the World:
//  1. A free cluster of unequal spheres colliding in zero gravity: linear momentum is conserved to
//     round-off while touching particles sit at different levels.
//  2. A heavy ball resting on light ones on a floor: the heavy one steps coarser than the light ones
//     it touches, and its height agrees with a fixed-step run at the light ones' finest step.
//  3. A small mill under particle levels: the collision spectra hold the World's dissipated energy,
//     the drive work balances dissipation and energy change, and 1 and 3 threads give the same state
//     and spectra.
//  4. Collision anticipation per pair caps an approaching pair at its own contact's level and no other
//     particle; a ball resting on a floor steps within its contact's stability bound.
//  5. A pile of big and light spheres settling in a box: levels per particle take no more steps than
//     one level per island, and no particle is pushed down to level_min.
//  6. A packed block converging in zero gravity, whose rejected chunks redo only the members the
//     rejection touches: linear momentum is conserved to round-off.
//  7. A few coarse members (3%) do not set an island's chunk.
// Expected values come from conservation laws, from fixed-step runs of the same scene and from the
// island control.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "engine/particle_level_doubling.h"
#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"
#include "tests/mill_scenes.h"
#include "tests/test_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

using namespace dem::test;

/// Largest level difference across a touching pair of the World now.
int level_spread_in_contacts(const World& world) {
  const PairContacts& c = world.pair_contacts();
  const State& s = world.state();
  int spread = 0;
  for (std::size_t k = 0; k < c.size(); ++k) spread = std::max(spread, std::abs(s.level[c.i[k]] - s.level[c.j[k]]));
  return spread;
}

/// Twelve spheres, radii 2 to 8 mm (masses 1:64), on a ring moving towards its centre with some
/// spin and tangential velocity, friction and damping, no gravity and no walls.
WorldConfig converging_cluster() {
  WorldConfig c = base_config(2e-5);
  ContactConfig contact;
  contact.normal_stiffness = 2e4;
  contact.normal_damping = {DampingKind::restitution, 0.6};
  contact.tangential_damping = {DampingKind::damping_ratio, 0.2};
  contact.sliding_friction = 0.4;
  c.contacts = {contact};
  for (int k = 0; k < 12; ++k) {
    const Real angle = 2 * std::acos(-1.0) * k / 12;
    const Real r = k % 3 == 0 ? 0.008 : (k % 3 == 1 ? 0.002 : 0.004);
    const Vec3 out(std::cos(angle), std::sin(angle), 0.1 * std::sin(3 * angle));
    const Real mass = std::pow(r / 0.002, 3);  // [kg]: dense, so that the contacts last many steps
    ParticleConfig p = particle(0.03 * out, -0.4 * out + Vec3(-out.y(), out.x(), 0) * 0.1, r, mass);
    p.angular_velocity = Vec3(0, 0, 10 * (k % 2 == 0 ? 1 : -1));
    c.particles.push_back(p);
  }
  set_doubling(c, 2e-5, -8, 4, 1e-3);
  c.integrator.particle_levels = true;
  return c;
}

/// Over `syncs` sync intervals of a World without walls or gravity: the largest change of its linear
/// momentum over the sum of m |v| at the start, the most contacts at once and the widest level spread
/// across a contact at a sync time.
struct MomentumWatch {
  Real worst = 0;
  std::size_t most_contacts = 0;
  int widest = 0;
};
MomentumWatch watch_momentum(World& world, int syncs) {
  const Vec3 p0 = world.linear_momentum();
  Real scale = 0;
  for (std::size_t q = 0; q < world.state().size(); ++q)
    scale += world.state().velocity[q].norm() / world.state().inv_mass[q];
  MomentumWatch w;
  for (int s = 0; s < syncs; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    w.worst = std::max(w.worst, (world.linear_momentum() - p0).norm() / scale);
    w.widest = std::max(w.widest, level_spread_in_contacts(world));
    w.most_contacts = std::max(w.most_contacts, world.pair_contacts().size());
  }
  return w;
}

TEST(ParticleLevels, AFewCoarseMembersDoNotSetTheChunk) {
  // 97 members at level 0 and 3 at level 5: the chunk is at level 0, and those 3 step at it.
  std::vector<int> levels(100, 0);
  std::fill(levels.end() - 3, levels.end(), 5);
  std::vector<Real> inv_mass(100, 1.0);
  EXPECT_EQ(chunk_level_bound(levels, inv_mass, 5), 0);
  // A fourth coarse member (4%) sets it.
  levels[96] = 5;
  EXPECT_EQ(chunk_level_bound(levels, inv_mass, 5), 5);
  EXPECT_EQ(chunk_level_bound(levels, inv_mass, 3), 3) << "never above the coarsest member's level";
  // Immovable members do not count, whatever their level.
  levels[96] = 0;
  levels.insert(levels.end(), 50, 9);
  inv_mass.insert(inv_mass.end(), 50, 0.0);
  EXPECT_EQ(chunk_level_bound(levels, inv_mass, 5), 0);
  // A small island: its one coarse member is more than 3% of it.
  EXPECT_EQ(chunk_level_bound({0, 0, 5}, {1.0, 1.0, 1.0}, 5), 5);
  EXPECT_EQ(chunk_level_bound({2, 4}, {0.0, 0.0}, 4), 4) << "nothing movable";
}

TEST(ParticleLevels, AFreeClusterKeepsItsMomentumWhileTouchingParticlesStepAtDifferentLevels) {
  World world(converging_cluster());
  const auto [worst, most_contacts, widest] = watch_momentum(world, 400);
  std::printf("cluster: |dP| / sum m|v| %.3e, widest level spread across a contact %d, contacts up to %zu\n", worst,
              widest, most_contacts);
  EXPECT_GE(most_contacts, 6u);
  EXPECT_GE(widest, 1);
  EXPECT_LT(worst, 1e-13);
}

/// 100 spheres, radii 2 and 3.5 mm by turns, on a jittered 5 x 5 x 4 lattice, all moving towards its
/// centre, with friction and damping, no gravity and no walls: one island of many members whose
/// chunks fail here and there.
WorldConfig converging_block() {
  WorldConfig c = converging_cluster();
  c.particles.clear();
  for (int k = 0; k < 100; ++k) {
    const Vec3 lattice(k % 5 - 2.0, (k / 5) % 5 - 2.0, k / 25 - 1.5);
    const Vec3 jitter(std::sin(7.0 * k), std::cos(11.0 * k), std::sin(13.0 * k + 1));
    const Vec3 x = 0.009 * lattice + 0.0008 * jitter;
    const Real r = k % 2 == 0 ? 0.002 : 0.0035;
    ParticleConfig p = particle(x, -8 * x, r, std::pow(r / 0.002, 3));
    p.angular_velocity = Vec3(0, 5 * std::sin(3.0 * k), 10 * std::cos(5.0 * k));
    c.particles.push_back(p);
  }
  return c;
}

// After a rejection only the members it touches are redone, against their partners' recorded paths,
// and those partners are paid the difference of what the redone members gave them: momentum stays
// balanced to round-off at every sync time, as with whole-island retries.
TEST(ParticleLevels, RetriesOfPartOfAnIslandKeepItsMomentum) {
  World world(converging_block());
  const auto [worst, most_contacts, widest] = watch_momentum(world, 200);
  const RunCounters& counters = world.counters();
  std::printf("block: |dP| / sum m|v| %.3e, contacts up to %zu, member retries %llu, rejected %llu of %llu "
              "particle-steps\n",
              worst, most_contacts, static_cast<unsigned long long>(counters.member_retries),
              static_cast<unsigned long long>(counters.rejected_steps),
              static_cast<unsigned long long>(counters.particle_steps));
  EXPECT_GE(most_contacts, 100u);  // packed: one island
  EXPECT_GT(counters.member_retries, 10u);
  EXPECT_LT(worst, 1e-13);
}

/// A 100 g ball resting on three 0.2 g balls on a floor, all released slightly above rest.
WorldConfig heavy_on_fines(bool doubling) {
  WorldConfig c = base_config(1e-5);
  c.model.gravity = Vec3(0, 0, -9.81);
  ContactConfig contact;
  contact.normal_stiffness = 1e4;
  contact.normal_damping = {DampingKind::damping_ratio, 0.3};
  contact.tangential_damping = {DampingKind::damping_ratio, 0.3};
  contact.sliding_friction = 0.5;
  c.contacts = {contact};
  c.walls = {plane(Vec3::Zero(), Vec3(0, 0, 1))};
  const Real small = 0.004, big = 0.02;
  for (int k = 0; k < 3; ++k) {
    const Real angle = 2 * std::acos(-1.0) * k / 3;
    c.particles.push_back(particle(Vec3(0.012 * std::cos(angle), 0.012 * std::sin(angle), small), Vec3::Zero(), small, 2e-4));
  }
  // Resting on the three: the centre distance to each small centre is small + big.
  const Real rise = std::sqrt((small + big) * (small + big) - 0.012 * 0.012);
  c.particles.push_back(particle(Vec3(0, 0, small + rise + 1e-5), Vec3::Zero(), big, 0.1));
  if (doubling) {
    set_doubling(c, 1e-5, -6, 6, 1e-3);
    c.integrator.particle_levels = true;
  }
  return c;
}

TEST(ParticleLevels, AHeavyBallOnLightOnesStepsCoarserThanThey) {
  World world(heavy_on_fines(true));
  int coarser_intervals = 0, intervals = 0;
  while (world.time() < 0.15) {
    ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
    ++intervals;
    const State& s = world.state();
    const int fines = std::max({s.level[0], s.level[1], s.level[2]});
    if (s.level[3] > fines && world.pair_contacts().size() == 3) ++coarser_intervals;
  }
  World fixed(heavy_on_fines(false));
  ASSERT_EQ(fixed.run_until(world.time()), StepStatus::ok);
  const Real dz = std::abs(world.state().position[3].z() - fixed.state().position[3].z());
  std::printf("heavy on fines: heavy ball coarser than the fines it rests on at %d of %d sync times; height "
              "against the fixed step %.3e m\n",
              coarser_intervals, intervals, dz);
  EXPECT_GT(coarser_intervals, intervals / 2);
  EXPECT_LT(dz, 1e-6);  // a quarter of a thousandth of the radius of the fines
}

// Anticipation per pair: two 100 g balls closing on each other within the chunk are capped so that
// the step they are accepted at (the half trial, one level below the full trial's level they carry)
// resolves their contact (t_c / 8 with their m* = 50 g), a ball closing on a wall so that it resolves
// its wall contact (m* = m); two 0.2 g balls nearly touching but not closing, and one far away, keep
// their levels (one cap for the whole island would hold them all at the approaching pair's level, or
// at the light pair's).
TEST(ParticleLevels, AnApproachingPairIsCappedAtItsOwnContactsLevelAndNoOtherParticleIs) {
  WorldConfig c = base_config(1e-5);
  ContactConfig contact;
  contact.normal_stiffness = 1e6;
  contact.normal_damping = {DampingKind::restitution, 0.5};
  c.contacts = {contact};
  const Real big = 0.02, small = 0.004;
  c.particles = {particle(Vec3(0, 0, 0), Vec3::Zero(), big, 0.1),
                 particle(Vec3(2 * big + 1e-3, 0, 0), Vec3(-1, 0, 0), big, 0.1),  // 1 mm apart, closing at 1 m/s
                 particle(Vec3(0, 0.1, 0), Vec3(0.3, 0, 0), small, 2e-4),
                 particle(Vec3(2 * small + 1e-4, 0.1, 0), Vec3(0.3, 0, 0), small, 2e-4),  // same velocity
                 particle(Vec3(0, -0.1, 0), Vec3(0, 1, 0), small, 2e-4),
                 particle(Vec3(-0.2 + big + 1e-3, 0.3, 0), Vec3(-1, 0, 0), big, 0.4)};  // 1 mm from the wall
  c.walls = {plane(Vec3(-0.2, 0, 0), Vec3(1, 0, 0))};
  c.broadphase.sort_interval = 0;  // slots in id order: the levels below are listed by id
  const World world(c);
  broadphase::CandidatePairs candidates;  // every pair
  const std::uint32_t n = 6;
  candidates.row_start.assign(1, 0);
  for (std::uint32_t a = 0; a < n; ++a) {
    for (std::uint32_t b = a + 1; b < n; ++b) candidates.partner.push_back(b);
    candidates.row_start.push_back(static_cast<std::uint32_t>(candidates.partner.size()));
  }
  DoublingSettings settings;
  settings.dt_base = 1e-5, settings.level_min = -6, settings.level_max = 6;
  const int chunk_level = 6;  // 0.64 ms: the heavy pair closes 0.64 mm of its 1 mm gap
  std::vector<int> levels(n, chunk_level);
  anticipate_per_pair(world.state(), candidates, world.materials(), world.walls(), Vec3::Zero(), settings,
                      chunk_level, levels);
  // t_c / 8 = pi sqrt(m* / k) / 8: 8.8e-5 s for the heavy pair (accepted at level 3, 8e-5 s, so the full
  // trial at 4); 2.5e-4 s for the 0.4 kg ball against the wall, m* = m (accepted at 4, full trial at 5).
  const auto resolving = [](Real m_star) {
    return static_cast<int>(std::floor(std::log2(std::acos(-1.0) * std::sqrt(m_star / 1e6) / 8 / 1e-5)));
  };
  ASSERT_EQ(resolving(0.05), 3);
  ASSERT_EQ(resolving(0.4), 4);
  EXPECT_EQ(levels, (std::vector<int>{4, 4, chunk_level, chunk_level, chunk_level, 5}));
  // At a chunk of level 5 both close 0.32 mm of their 1 mm gaps: more than two steps away, no cap
  // (it would lower the heavy pair to 4).
  std::vector<int> finer(n, 5);
  anticipate_per_pair(world.state(), candidates, world.materials(), world.walls(), Vec3::Zero(), settings, 5, finer);
  EXPECT_EQ(finer, std::vector<int>(n, 5));
}

// Stability per member: a 100 g ball resting on a floor of stiffness 1e4 N/m, nudged at 1 mm/s, at a
// loose tolerance. Near rest both trials agree at almost any step, so the error control alone would take
// the longest step there is (10.24 ms, beyond velocity Verlet's limit 2 sqrt(m / k) = 6.3 ms); the cap
// keeps the step it is accepted at within sqrt(m / k) = 3.16 ms (level 8, 2.56 ms), its full trial at
// level 9, and the nudge dies out. The ball climbs from finer levels, and a promotion stops one level
// below the cap (there the full trial would reach Verlet's limit), so it is accepted at level 7.
TEST(ParticleLevels, ABallRestingOnAFloorStepsWithinItsContactsStabilityBound) {
  WorldConfig c = base_config(1e-5);
  c.model.gravity = Vec3(0, 0, -9.81);
  ContactConfig contact;
  contact.normal_stiffness = 1e4;
  contact.normal_damping = {DampingKind::damping_ratio, 0.3};
  c.contacts = {contact};
  c.walls = {plane(Vec3::Zero(), Vec3(0, 0, 1))};
  const Real radius = 0.02, mass = 0.1, rest_overlap = mass * 9.81 / 1e4;
  c.particles = {particle(Vec3(0, 0, radius - rest_overlap), Vec3(0, 0, -1e-3), radius, mass)};
  set_doubling(c, 1e-5, -6, 10, 1);
  c.integrator.particle_levels = true;
  World world(c);
  const int accepted_cap = static_cast<int>(std::floor(std::log2(std::sqrt(mass / 1e4) / 1e-5)));
  ASSERT_EQ(accepted_cap, 8);
  for (int s = 0; s < 20; ++s) {
    ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
    ASSERT_EQ(world.wall_contacts().size(), 1u);
  }
  // The histogram counts accepted steps per level from level_min = -6.
  const std::vector<std::uint64_t>& histogram = world.counters().level_histogram;
  int highest = -100;
  for (std::size_t l = 0; l < histogram.size(); ++l)
    if (histogram[l] > 0) highest = static_cast<int>(l) - 6;
  const Real drift = std::abs(world.state().position[0].z() - (radius - rest_overlap));
  std::printf("ball on a floor: highest accepted level %d (cap %d), drift from rest %.3e m\n", highest,
              accepted_cap, drift);
  EXPECT_EQ(highest, accepted_cap - 1);
  EXPECT_LT(drift, 1e-3 * rest_overlap);
}

// 27 spheres of 4-5 mm, every third replaced by a light one of 1.5 mm, falling into a box and settling
// (24 sync intervals, 0.5 s). Members take many steps in a chunk of their island's coarsest member:
// weighed over the whole chunk against a floor that does not grow with it, a resting member's error
// can only be met at ever finer steps, and the pile sinks to level_min.
TEST(ParticleLevels, ASettlingPileOfBigAndLightSpheresStepsNoFinerThanOneLevelPerIsland) {
  std::uint64_t steps[2] = {0, 0};
  for (const bool per_particle : {false, true}) {
    WorldConfig c = falling_box_scene(3, 3, 3, 9);
    for (std::size_t p = 0; p < c.particles.size(); p += 3) c.particles[p].radius = 0.0015;
    c.integrator.control = Control::doubling;
    c.integrator.particle_levels = per_particle;
    World world(c);
    for (int s = 0; s < 24; ++s) ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
    ASSERT_GT(world.pair_contacts().size(), 15u) << "the pile has formed";
    const RunCounters& counters = world.counters();
    steps[per_particle] = counters.particle_steps;
    EXPECT_EQ(counters.forced_steps, 0u);
    ASSERT_FALSE(counters.level_histogram.empty());
    EXPECT_EQ(counters.level_histogram.front(), 0u) << "steps at level_min";
  }
  std::printf("settling pile: %llu particle-steps per particle against %llu per island\n",
              static_cast<unsigned long long>(steps[1]), static_cast<unsigned long long>(steps[0]));
  EXPECT_LE(steps[1], steps[0]);
}

TEST(ParticleLevels, AMillBooksItsSpectraAndBalancesItsEnergyForAnyThreadCount) {
  const AllowThreads allow_three(3);
  Real start_energy = 0;
  auto run = [&start_energy](int threads, bool wall_lists = true) {
    const Scene scene = load_scene_text(mill_scene(8, 0.75, "count = 30"), "mill.toml", ".",
                                        {"integrator.control=\"doubling\"", "integrator.particle_levels=true",
                                         "run.threads=" + std::to_string(threads),
                                         std::string("broadphase.wall_lists=") + (wall_lists ? "true" : "false")});
    auto world = std::make_unique<World>(scene.world);
    start_energy = world->energies().total();
    EXPECT_EQ(world->run_until(0.4), StepStatus::ok);
    return world;
  };
  const std::unique_ptr<World> world = run(1);
  const CollisionSpectra& spectra = *world->collision_spectra();
  EXPECT_GT(spectra.events(CollisionSpectra::ball_ball), 100u);
  EXPECT_GT(spectra.events(CollisionSpectra::ball_wall), 10u);
  EXPECT_GT(world->counters().rejected_steps, 0u);
  EXPECT_GT(world->counters().member_retries, 0u);  // the books below merge retries with first tries
  const Real lost = world->dissipated_energy();
  ASSERT_GT(lost, 0);
  const Real open = live_dissipation(world->pair_contacts().work, world->pair_contacts().elastic) +
                    live_dissipation(world->wall_contacts().work, world->wall_contacts().elastic);
  EXPECT_NEAR(spectra.dissipated() + open, lost, 1e-9 * lost);
  // Drive work against dissipation and energy change: the residual is the integrator's own energy error.
  const Real work = world->wall_work(), change = world->energies().total() - start_energy;
  std::printf("mill under particle levels: drive work %.4g J, dissipated %.4g J, energy change %.4g J: residual %.3g "
              "of the dissipation\n",
              work, lost, change, (work - lost - change) / lost);
  EXPECT_LT(std::abs(work - lost - change), 0.03 * lost);
  const std::unique_ptr<World> three = run(3);
  ASSERT_EQ(three->thread_count(), 3);
  EXPECT_EQ(three->state_hash(), world->state_hash());
  // The groups' wall lists only skip walls out of reach: every wall tested gives the same run.
  EXPECT_EQ(run(1, false)->state_hash(), world->state_hash());
  const CollisionSpectra& other = *three->collision_spectra();
  for (auto kind : {CollisionSpectra::ball_ball, CollisionSpectra::ball_wall}) {
    EXPECT_EQ(other.events(kind), spectra.events(kind));
    for (int b = 0; b < CollisionSpectra::bin_count; ++b)
      EXPECT_EQ(other.energy(kind, CollisionSpectra::impact, b), spectra.energy(kind, CollisionSpectra::impact, b));
  }
}

}  // namespace
}  // namespace dem
