// Determinism of every shipped scene (issue: reliability): the state hash after 20 sync intervals is
// the same for 1, 2, 3 and 8 threads and for two runs in a row, with velocity Verlet and, where the
// scene is frictionless or can be made so, with the exact stepper. One test per scene and control, so
// a filter can pick scenes (the ThreadSanitizer subset, tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/thread_support.h"

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

void expect_scene_thread_independent(const std::string& name, bool doubling) {
  const test::AllowThreads allow_eight(8);
  const std::vector<std::string> overrides =
      doubling ? std::vector<std::string>{"integrator.control=doubling", "integrator.level_max=2"}
               : std::vector<std::string>{};
  const Scene scene = load_scene(std::string(DEM_SOURCE_DIR) + "/scenes/" + name + ".toml", overrides);
  expect_thread_independent(scene.world, "verlet");
  WorldConfig exact = scene.world;
  exact.integrator.method = Method::exact;
  for (ContactConfig& c : exact.contacts)
    c.sliding_friction = c.static_friction = c.rolling_friction = c.rolling_static_friction = 0;
  expect_thread_independent(exact, "exact (frictionless)");
}

/// The names (file stems) of every scene in scenes/, sorted.
std::vector<std::string> shipped_scenes() {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(DEM_SOURCE_DIR) + "/scenes"))
    if (entry.path().extension() == ".toml") names.push_back(entry.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

class SceneDeterminism : public ::testing::TestWithParam<std::string> {};

TEST(SceneDeterminismCorpus, AtLeastSixScenesAreShipped) { EXPECT_GE(shipped_scenes().size(), 6u); }

TEST_P(SceneDeterminism, HasOneHashForAnyThreadCount) { expect_scene_thread_independent(GetParam(), false); }

TEST_P(SceneDeterminism, HasOneHashForAnyThreadCountUnderDoubling) { expect_scene_thread_independent(GetParam(), true); }

// Test names need letters, digits and underscores only.
INSTANTIATE_TEST_SUITE_P(Shipped, SceneDeterminism, ::testing::ValuesIn(shipped_scenes()),
                         [](const ::testing::TestParamInfo<std::string>& p) {
                           std::string name = p.param;
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

}  // namespace
}  // namespace dem
