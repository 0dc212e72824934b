// World::memory_bytes (world_memory.cpp): it counts what is allocated (capacities, scratch included),
// and the dense bed stays within its budget of bytes per particle.
#include <gtest/gtest.h>

#include <iostream>
#include <memory>
#include <string>

#include "engine/world.h"

namespace dem {
namespace {

std::string scene(const std::string& name) { return std::string(DEM_SOURCE_DIR) + "/scenes/" + name; }

// Prints the parts per particle and returns their sum.
std::size_t print_parts(const World& w) {
  const double n = static_cast<double>(w.particle_count());
  std::size_t sum = 0;
  for (const MemoryPart& p : w.memory_breakdown()) {
    std::cout << "  " << p.name << ": " << p.bytes / n << " B per particle\n";
    sum += p.bytes;
  }
  return sum;
}

std::size_t part(const World& w, const std::string& name) {
  for (const MemoryPart& p : w.memory_breakdown())
    if (p.name == name) return p.bytes;
  ADD_FAILURE() << "no memory part named " << name;
  return 0;
}

// 20,000 settled spheres, about 1.8 pair contacts each, fixed-step Verlet on 2 threads: 1,030 bytes per
// particle. The persistent pair list holds a slot per candidate pair (about 5.2 per particle at the
// bed's 2 mm skin, 100 bytes each: spring, mode, force, moment, overlap and books) and the compact
// list that outputs read is kept beside it; the list rebuilt every step needed 562.
TEST(WorldMemory, DenseBedStaysWithinItsBytesPerParticle) {
  const std::unique_ptr<World> world = World::load(scene("dense_bed.toml"), {"run.threads=2"});
  ASSERT_EQ(world->run_until(0.0003), StepStatus::ok);
  const double n = static_cast<double>(world->particle_count());
  EXPECT_EQ(world->memory_bytes(), print_parts(*world));
  EXPECT_GT(world->pair_contacts().size(), world->particle_count()) << "the bed is dense";
  EXPECT_LT(world->memory_bytes() / n, 1240) << "1,030 reached, plus 20%";
  EXPECT_LT(part(*world, "persistent pair list") / n, 625) << "520 reached, plus 20%";
  // The particle arrays are reserved for the scene's particles, not grown by doubling.
  EXPECT_LT(part(*world, "state") / n, 160);
}

// The same bed under step doubling, where the bed is one island, on 1 thread (each thread that runs
// an island keeps its own scratch, so which threads grow one is up to the scheduler). One level per
// island copies the bed into the island (state, candidates, contacts) and each trial copies the
// island again. Levels per particle keep two trial groups, each with a state, the state its contacts
// are evaluated in, its contacts split by level, each contact's impulse, each particle's step and the
// steps a retry replays; and a retry's two smaller groups.
std::size_t doubling_bytes_per_particle(bool particle_levels) {
  const std::unique_ptr<World> world =
      World::load(scene("dense_bed.toml"), {"run.threads=1", "integrator.control=doubling", "integrator.tolerance=1e-2",
                                            std::string("integrator.particle_levels=") + (particle_levels ? "true" : "false")});
  EXPECT_EQ(world->run_until(0.0003), StepStatus::ok);
  std::cout << (particle_levels ? "levels per particle" : "one level per island") << ":\n";
  print_parts(*world);
  return world->memory_bytes() / world->particle_count();
}

TEST(WorldMemory, DenseBedUnderDoublingStaysWithinItsBytesPerParticle) {
  const std::size_t island = doubling_bytes_per_particle(false);
  const std::size_t levels = doubling_bytes_per_particle(true);
  ::testing::Test::RecordProperty("bytes_per_particle_one_level_per_island", std::to_string(island));
  ::testing::Test::RecordProperty("bytes_per_particle_levels_per_particle", std::to_string(levels));
  EXPECT_LT(island, 3790u) << "3,157 reached, plus 20%";
  EXPECT_LT(levels, 9780u) << "8,153 reached, plus 20%";
}

TEST(WorldMemory, CountsCapacityNotSize) {
  // Two spheres meet head-on and part: the contact list ends empty but keeps its capacity (no
  // allocation when the next contact forms), and the count keeps those bytes.
  const std::unique_ptr<World> world = World::load(scene("head_on.toml"), {"run.threads=1"});
  while (world->pair_contacts().size() == 0) ASSERT_EQ(world->advance_sync_interval(), StepStatus::ok);
  const std::size_t touching = part(*world, "pair contacts");
  ASSERT_EQ(world->run_until(0.02), StepStatus::ok);
  const PairContacts& pairs = world->pair_contacts();
  ASSERT_EQ(pairs.size(), 0u) << "the spheres have parted";
  ASSERT_GT(pairs.key.capacity(), 0u);
  EXPECT_EQ(part(*world, "pair contacts"), touching);
  EXPECT_GE(part(*world, "pair contacts"),
            pairs.key.capacity() * sizeof(std::uint64_t) + pairs.force.capacity() * sizeof(Vec3));
  const State& s = world->state();
  EXPECT_GE(part(*world, "state"), s.position.capacity() * sizeof(Vec3) + s.radius.capacity() * sizeof(Real));
}

}  // namespace
}  // namespace dem
