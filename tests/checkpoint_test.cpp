// Restart: 2N intervals straight against N, checkpoint, restore into a new world, N more: bit-equal
// (docs/design.md, Checkpoints). Damaged files and checkpoints of other physics are refused.
#include <gtest/gtest.h>

#include <algorithm>
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
  first.save_checkpoint(path.string(), 42);

  World resumed(config);
  resumed.load_checkpoint(path.string(), 42);
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
  world.save_checkpoint(path.string(), 7);
  World other(config);
  const std::uint64_t before = other.state_hash();
  EXPECT_THROW(other.load_checkpoint(path.string(), 8), std::runtime_error);
  EXPECT_EQ(other.state_hash(), before) << "a refused checkpoint leaves the world untouched";

  // Truncated: the checksum no longer matches.
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, size - 5);
  EXPECT_THROW(other.load_checkpoint(path.string(), 7), std::runtime_error);
  // Not a checkpoint at all.
  std::ofstream(path) << "hello";
  EXPECT_THROW(other.load_checkpoint(path.string(), 7), std::runtime_error);
  EXPECT_EQ(other.state_hash(), before);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace dem
