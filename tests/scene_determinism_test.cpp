// Determinism of every shipped scene (issue: reliability): the state hash after 20 sync intervals is
// the same for 1, 2, 3 and 8 threads and for two runs in a row, with velocity Verlet and, where the
// scene is frictionless or can be made so, with the exact stepper.
#include <gtest/gtest.h>

#include <filesystem>

#include <tbb/global_control.h>

#include "engine/scene_loader.h"
#include "engine/world.h"

namespace dem {
namespace {

std::uint64_t hash_after(WorldConfig config, int threads) {
  config.threads = threads;
  World world(config);
  for (int s = 0; s < 20; ++s) EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
  return world.state_hash();
}

void expect_thread_independent(const WorldConfig& config, const std::string& what) {
  const std::uint64_t one = hash_after(config, 1);
  EXPECT_EQ(hash_after(config, 1), one) << what << ": two runs in a row";
  for (int threads : {2, 3, 8}) EXPECT_EQ(hash_after(config, threads), one) << what << ", " << threads << " threads";
}

void expect_every_scene_thread_independent(bool doubling) {
  tbb::global_control allow_eight(tbb::global_control::max_allowed_parallelism, 8);
  int scenes = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(DEM_SOURCE_DIR) + "/scenes")) {
    if (entry.path().extension() != ".toml") continue;
    ++scenes;
    SCOPED_TRACE(entry.path().filename().string());
    const std::vector<std::string> overrides =
        doubling ? std::vector<std::string>{"integrator.control=doubling", "integrator.level_max=2"}
                 : std::vector<std::string>{};
    const Scene scene = load_scene(entry.path().string(), overrides);
    expect_thread_independent(scene.world, "verlet");
    WorldConfig exact = scene.world;
    exact.integrator.method = Method::exact;
    for (ContactConfig& c : exact.contacts)
      c.sliding_friction = c.static_friction = c.rolling_friction = c.rolling_static_friction = 0;
    expect_thread_independent(exact, "exact (frictionless)");
  }
  EXPECT_GE(scenes, 6);
}

TEST(SceneDeterminism, EveryShippedSceneHasOneHashForAnyThreadCount) { expect_every_scene_thread_independent(false); }

TEST(SceneDeterminism, EveryShippedSceneHasOneHashForAnyThreadCountUnderDoubling) {
  expect_every_scene_thread_independent(true);
}

}  // namespace
}  // namespace dem
