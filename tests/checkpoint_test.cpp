// Restart: 2N intervals straight against N, checkpoint, restore into a new world, N more: bit-equal
// (docs/design.md, Checkpoints). Damaged files and checkpoints of other physics are refused. A start
// from a checkpoint under other integrator settings takes its particles, contacts and books as they
// were and goes on in time from it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "engine/world.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

std::filesystem::path temp_file(const std::string& name) {
  return std::filesystem::temp_directory_path() / ("dem_checkpoint_test_" + name + "_" + std::to_string(::getpid()));
}

void expect_restart_is_bit_for_bit(const WorldConfig& config, int intervals = 300);

TEST(Checkpoint, RestoredRunContinuesBitForBit) { expect_restart_is_bit_for_bit(test::falling_box_scene(6, 6, 6, 3)); }

TEST(Checkpoint, RestoredExactRunContinuesBitForBit) {
  WorldConfig config = test::falling_box_scene(6, 6, 6, 3);
  config.integrator.method = Method::exact;  // frictionless: what the exact stepper handles so far
  config.contacts[0].sliding_friction = 0;
  config.contacts[0].rolling_friction = 0;
  expect_restart_is_bit_for_bit(config);
}

// Step doubling with a level per particle: the checkpoint carries each particle's level (State::level)
// and the contact history of every level's lists, so a resumed run takes the same steps.
TEST(Checkpoint, RestoredRunWithLevelsPerParticleContinuesBitForBit) {
  WorldConfig config = test::falling_box_scene(3, 3, 3, 9);
  for (std::size_t p = 0; p < config.particles.size(); p += 3) config.particles[p].radius = 0.0015;  // light ones
  config.integrator.control = Control::doubling;
  config.integrator.particle_levels = true;
  constexpr int intervals = 8;  // of 0.02 s: the pile is forming
  World probe(config);
  for (int s = 0; s < intervals; ++s) ASSERT_EQ(probe.advance_sync_interval(), StepStatus::ok);
  const auto& level = probe.state().level;
  ASSERT_NE(*std::min_element(level.begin(), level.end()), *std::max_element(level.begin(), level.end()))
      << "the checkpoint must hold particles at different levels";
  expect_restart_is_bit_for_bit(config, intervals);
}

void expect_restart_is_bit_for_bit(const WorldConfig& config, int intervals) {
  const int n = intervals;
  World straight(config);
  for (int s = 0; s < 2 * n; ++s) ASSERT_EQ(straight.advance_sync_interval(), StepStatus::ok);

  World first(config);
  for (int s = 0; s < n; ++s) ASSERT_EQ(first.advance_sync_interval(), StepStatus::ok);
  ASSERT_GT(first.pair_contacts().size(), 0u) << "the checkpoint must carry contact history";
  const auto path = temp_file("restart");
  first.save_checkpoint(path.string(), {42, 42});

  World resumed(config);
  resumed.load_checkpoint(path.string(), {42, 42});
  EXPECT_EQ(resumed.state_hash(), first.state_hash());
  EXPECT_EQ(resumed.time(), first.time());
  for (int s = 0; s < n; ++s) ASSERT_EQ(resumed.advance_sync_interval(), StepStatus::ok);
  EXPECT_EQ(resumed.state_hash(), straight.state_hash());
  EXPECT_EQ(resumed.counters().particle_steps, straight.counters().particle_steps);
  EXPECT_EQ(resumed.counters().pair_rebuilds, straight.counters().pair_rebuilds);
  EXPECT_EQ(resumed.dissipated_energy(), straight.dissipated_energy());
  std::filesystem::remove(path);
}

TEST(Checkpoint, RefusesOtherPhysicsAndDamagedFiles) {
  const WorldConfig config = test::falling_box_scene(3, 3, 3, 5);
  World world(config);
  for (int s = 0; s < 50; ++s) world.advance_sync_interval();
  const auto path = temp_file("refuse");
  world.save_checkpoint(path.string(), {7, 7});
  World other(config);
  const std::uint64_t before = other.state_hash();
  EXPECT_THROW(other.load_checkpoint(path.string(), {8, 8}), std::runtime_error);
  EXPECT_EQ(other.state_hash(), before) << "a refused checkpoint leaves the world untouched";

  // Truncated: the checksum no longer matches.
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size - 5);
  EXPECT_THROW(other.load_checkpoint(path.string(), {7, 7}), std::runtime_error);
  // Not a checkpoint at all.
  std::ofstream(path) << "hello";
  EXPECT_THROW(other.load_checkpoint(path.string(), {7, 7}), std::runtime_error);
  EXPECT_EQ(other.state_hash(), before);
  std::filesystem::remove(path);
}

// The same particles, walls and contacts under the same settings: with walls at rest nothing depends
// on the time's rounding, so the started run follows the straight one bit for bit; its clock and
// counters start anew at the checkpoint's time.
TEST(Checkpoint, StartUnderTheSameSettingsFollowsTheStraightRun) {
  const WorldConfig config = test::falling_box_scene(4, 4, 4, 21);
  constexpr int n = 200;
  World straight(config);
  for (int s = 0; s < 2 * n; ++s) ASSERT_EQ(straight.advance_sync_interval(), StepStatus::ok);
  World first(config);
  for (int s = 0; s < n; ++s) ASSERT_EQ(first.advance_sync_interval(), StepStatus::ok);
  ASSERT_GT(first.pair_contacts().size(), 0u) << "the checkpoint must carry contact history";
  const auto path = temp_file("start_same");
  first.save_checkpoint(path.string(), {1, 9});

  World started(config);
  started.start_from_checkpoint(path.string(), {2, 9});  // another physics hash: allowed
  EXPECT_EQ(started.time(), first.time());
  EXPECT_EQ(started.counters().particle_steps, 0u);
  EXPECT_EQ(started.pair_contacts().size(), first.pair_contacts().size());
  EXPECT_EQ(started.dissipated_energy(), first.dissipated_energy());
  for (int s = 0; s < n; ++s) ASSERT_EQ(started.advance_sync_interval(), StepStatus::ok);
  EXPECT_NEAR(started.time(), straight.time(), 1e-12);
  EXPECT_EQ(started.counters().particle_steps, straight.counters().particle_steps / 2);
  const State& a = started.state();
  const State& b = straight.state();
  for (std::size_t p = 0; p < a.size(); ++p) {
    EXPECT_EQ(a.position[p], b.position[p]) << "particle " << p;
    EXPECT_EQ(a.velocity[p], b.velocity[p]) << "particle " << p;
    EXPECT_EQ(a.angular_velocity[p], b.angular_velocity[p]) << "particle " << p;
  }
  EXPECT_EQ(started.dissipated_energy(), straight.dissipated_energy());
  std::filesystem::remove(path);
}

// From a fixed step into step doubling with levels per particle: the particles and springs are the
// checkpoint's, the levels start anew and spread, the energy balance carries across the switch, and
// the pile's centre of mass follows the fixed-step run's.
TEST(Checkpoint, StartUnderStepDoublingGoesOnFromTheFixedStepsState) {
  WorldConfig config = test::falling_box_scene(3, 3, 3, 9);
  for (std::size_t p = 0; p < config.particles.size(); p += 3) config.particles[p].radius = 0.0015;  // light ones
  config.broadphase.sort_interval = 1000;  // the fixed step re-sorts its particles in space
  constexpr int n = 5000;  // of 2e-5 s: the pile is forming
  World fixed(config);
  for (int s = 0; s < n; ++s) ASSERT_EQ(fixed.advance_sync_interval(), StepStatus::ok);
  const auto path = temp_file("start_doubling");
  fixed.save_checkpoint(path.string(), {1, 9});
  ASSERT_GT(fixed.pair_contacts().size(), 0u);
  const Real t0 = fixed.time();

  WorldConfig doubling = config;
  doubling.integrator.control = Control::doubling;
  doubling.integrator.particle_levels = true;
  doubling.integrator.tolerance = 1e-4;
  doubling.integrator.dt_base = 2e-5;
  doubling.integrator.level_min = -6;
  doubling.integrator.level_max = 4;
  World started(doubling);
  started.start_from_checkpoint(path.string(), {2, 9});
  EXPECT_EQ(started.time(), t0);
  EXPECT_EQ(started.state_hash() == fixed.state_hash(), false) << "the clocks differ";
  const State& s0 = started.state();
  EXPECT_TRUE(s0.slots_follow_ids()) << "step doubling keeps slots in id order";
  EXPECT_FALSE(fixed.state().slots_follow_ids()) << "the fixed step re-sorted them";
  for (std::size_t p = 0; p < s0.size(); ++p) {
    ASSERT_EQ(s0.position[p], fixed.position(s0.id[p]));
    ASSERT_EQ(s0.velocity[p], fixed.velocity(s0.id[p]));
    ASSERT_EQ(s0.level[p], 0) << "levels start as a new run's";
  }
  const PairContacts& c0 = started.pair_contacts();
  const PairContacts& f0 = fixed.pair_contacts();
  ASSERT_EQ(c0.size(), f0.size());
  EXPECT_TRUE(std::is_sorted(c0.key.begin(), c0.key.end()));
  const std::vector<std::uint32_t> f_order = key_order(f0.key);  // the fixed step's list is in row order
  for (std::size_t k = 0; k < c0.size(); ++k) {
    EXPECT_EQ(c0.key[k], f0.key[f_order[k]]);
    EXPECT_EQ(c0.tangential_spring[k], f0.tangential_spring[f_order[k]]) << "the springs are the checkpoint's";
  }
  const Real until = t0 + 0.1;
  ASSERT_EQ(started.run_until(until), StepStatus::ok);
  ASSERT_EQ(fixed.run_until(until), StepStatus::ok);
  EXPECT_GT(started.counters().accepted_steps, 0u);
  const auto& level = started.state().level;
  EXPECT_NE(*std::min_element(level.begin(), level.end()), *std::max_element(level.begin(), level.end()))
      << "doubling chose levels per particle";
  const EnergyBalance balance = started.energy_balance();
  EXPECT_LT(std::abs(balance.error), 1e-3 * balance.scale) << "the balance goes on from the checkpoint's books";
  EXPECT_GT(started.dissipated_energy(), fixed.dissipated_energy() * 0.5);
  const auto centre_height = [](const State& s) {
    Real m = 0, mz = 0;
    for (std::size_t p = 0; p < s.size(); ++p) {
      m += 1 / s.inv_mass[p];
      mz += s.position[p].z() / s.inv_mass[p];
    }
    return mz / m;
  };
  EXPECT_NEAR(centre_height(started.state()), centre_height(fixed.state()), 0.02 * centre_height(fixed.state()));
  std::filesystem::remove(path);
}

// What a start refuses: other particles, materials or walls (another body hash), another method; a
// resume under other integrator settings is refused and pointed to a start.
TEST(Checkpoint, StartRefusesAnotherBodyOrMethod) {
  const WorldConfig config = test::falling_box_scene(3, 3, 3, 5);
  World world(config);
  for (int s = 0; s < 50; ++s) world.advance_sync_interval();
  const auto path = temp_file("start_refuse");
  world.save_checkpoint(path.string(), {7, 70});
  World other(config);
  const std::uint64_t before = other.state_hash();
  EXPECT_THROW(other.start_from_checkpoint(path.string(), {7, 71}), std::runtime_error);
  EXPECT_EQ(other.state_hash(), before) << "a refused checkpoint leaves the world untouched";
  try {
    other.load_checkpoint(path.string(), {8, 70});
    ADD_FAILURE() << "a resume under other integrator settings must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("--from"), std::string::npos) << e.what();
  }
  WorldConfig exact = config;
  exact.integrator.method = Method::exact;
  World exact_world(exact);
  try {
    exact_world.start_from_checkpoint(path.string(), {8, 70});
    ADD_FAILURE() << "a start under another method must be refused";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("verlet"), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

// A run started from a checkpoint writes checkpoints of its own, which resume bit for bit (they carry
// its clock's origin).
TEST(Checkpoint, AStartedRunResumesBitForBit) {
  const WorldConfig config = test::falling_box_scene(3, 3, 3, 11);
  World first(config);
  for (int s = 0; s < 100; ++s) ASSERT_EQ(first.advance_sync_interval(), StepStatus::ok);
  const auto origin = temp_file("origin");
  first.save_checkpoint(origin.string(), {1, 9});
  WorldConfig doubling = config;
  doubling.integrator.control = Control::doubling;
  doubling.integrator.dt_base = 2e-5;
  doubling.integrator.level_max = 3;
  World straight(doubling), started(doubling), resumed(doubling);
  straight.start_from_checkpoint(origin.string(), {2, 9});
  started.start_from_checkpoint(origin.string(), {2, 9});
  for (int s = 0; s < 40; ++s) ASSERT_EQ(straight.advance_sync_interval(), StepStatus::ok);
  for (int s = 0; s < 20; ++s) ASSERT_EQ(started.advance_sync_interval(), StepStatus::ok);
  const auto path = temp_file("started");
  started.save_checkpoint(path.string(), {2, 9});
  resumed.load_checkpoint(path.string(), {2, 9});
  EXPECT_EQ(resumed.time(), started.time());
  for (int s = 0; s < 20; ++s) ASSERT_EQ(resumed.advance_sync_interval(), StepStatus::ok);
  EXPECT_EQ(resumed.time(), straight.time());
  EXPECT_EQ(resumed.state_hash(), straight.state_hash());
  std::filesystem::remove(origin);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace dem
