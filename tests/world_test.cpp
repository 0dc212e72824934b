// World-level contracts an embedding program relies on: immovable particles (infinite mass) never
// produce NaN, even touching each other or a wall, and a configuration a run cannot survive is
// refused at construction.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/mill_scenes.h"

namespace dem {
namespace {

TEST(World, ImmovableParticlesTouchingEachOtherAndAWallStayFinite) {
  const Real inf = std::numeric_limits<Real>::infinity();
  for (Method method : {Method::verlet, Method::exact}) {
    WorldConfig c;
    c.integrator.method = method;
    c.integrator.dt = 1e-4;
    c.model.gravity = Vec3(0, 0, -9.81);
    c.contacts[0].normal_damping = {DampingKind::damping_ratio, 0.3};
    WallConfig floor;
    floor.kind = WallKind::plane;
    c.walls = {floor};
    // Two immovable spheres overlapping each other and the floor, a movable one resting on them.
    c.particles = {test::particle(Vec3(0, 0, 0.099), Vec3::Zero(), 0.1, inf),
                   test::particle(Vec3(0.199, 0, 0.099), Vec3::Zero(), 0.1, inf),
                   test::particle(Vec3(0.1, 0, 0.27), Vec3::Zero(), 0.1, 1.0)};
    World w(c);
    for (int s = 0; s < 2000; ++s) ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
    EXPECT_TRUE(std::isfinite(w.dissipated_energy()));
    EXPECT_TRUE(w.wall_load(0).force.allFinite());
    EXPECT_EQ(w.state().position[0], Vec3(0, 0, 0.099)) << "an immovable particle does not move";
    EXPECT_GT(w.state().position[2].z(), 0.27 - 0.02) << "the movable sphere rests on the immovable ones";
  }
}

TEST(World, RefusesWhatARunCannotSurvive) {
  WorldConfig c;
  c.particles = {test::particle(Vec3::Zero(), Vec3::Zero(), 0.1, 1)};
  c.integrator.dt = 0;
  EXPECT_THROW(World w(c), std::invalid_argument);
  c.integrator.dt = 1e-4;
  c.particles[0].radius = -1;
  EXPECT_THROW(World w(c), std::invalid_argument);
  c.particles[0].radius = 0.1;
  c.particles[0].velocity.x() = std::numeric_limits<Real>::quiet_NaN();
  EXPECT_THROW(World w(c), std::invalid_argument);
  c.particles[0].velocity.x() = 0;
  c.contacts[0].normal_stiffness = 0;
  EXPECT_THROW(World w(c), std::invalid_argument);
}

// A fixed Verlet step books how far the next step carries each particle, h |v| / R, and keeps the
// largest (the step watch); a state that overflows stops the run instead of stepping on.
TEST(World, FixedVerletStepBooksTheLongestTravelAndStopsOnAnOverflow) {
  WorldConfig c;
  c.model.gravity = Vec3::Zero();
  c.integrator.dt = 1e-3;
  // Apart and force-free: each keeps its velocity. The second travels 4e-3 m per step, 0.08 radii.
  c.particles = {test::particle(Vec3(0, 0, 0), Vec3(3, 0, 0), 0.1, 1),
                 test::particle(Vec3(1, 0, 0), Vec3(0, 4, 0), 0.05, 1)};
  World w(c);
  ASSERT_EQ(w.advance_sync_interval(), StepStatus::ok);
  EXPECT_NEAR(w.longest_step_travel_seen().value, 1e-3 * 4 / 0.05, 1e-15);
  EXPECT_EQ(w.longest_step_travel_seen().particle, 1u);
  EXPECT_DOUBLE_EQ(w.longest_step_travel_seen().time, 1e-3);

  // 1e300 m/s for 1e10 s overflows the position: the first step reports it.
  c.integrator.dt = 1e10;
  c.particles[1].velocity = Vec3(0, 1e300, 0);
  World overflow(c);
  EXPECT_EQ(overflow.advance_sync_interval(), StepStatus::non_finite);
}

// A scene without a skin gets one chosen from its speeds (fixed-step Verlet): the candidate pairs
// only have to hold every contact, so the states are those of the default skin's run, bit for bit,
// while a tumbling mill charge rebuilds its candidates several times less often.
TEST(World, SkinChosenFromSpeedsChangesOnlyHowOftenCandidatesAreRebuilt) {
  const Scene scene = load_scene_text(test::mill_scene(8, 0.75, "count = 200"), "mill.toml", ".");
  WorldConfig fixed_skin = scene.world;
  fixed_skin.broadphase.skin = 0.1 * test::ball_radius;  // the default, stated
  World chosen(scene.world), stated(fixed_skin);
  ASSERT_TRUE(chosen.skin_is_chosen());
  ASSERT_FALSE(stated.skin_is_chosen());
  EXPECT_EQ(chosen.skin(), stated.skin());
  ASSERT_EQ(chosen.run_until(0.6), StepStatus::ok);
  ASSERT_EQ(stated.run_until(0.6), StepStatus::ok);
  EXPECT_EQ(chosen.state_hash(), stated.state_hash());
  EXPECT_GT(chosen.candidate_skin(), chosen.skin());
  EXPECT_LE(chosen.candidate_skin(), 10 * chosen.skin());
  const double ratio = static_cast<double>(stated.counters().pair_rebuilds) / chosen.counters().pair_rebuilds;
  RecordProperty("rebuild_ratio", std::to_string(ratio));
  EXPECT_GT(ratio, 2) << stated.counters().pair_rebuilds << " rebuilds at the default skin against "
                      << chosen.counters().pair_rebuilds << " with the skin chosen from the speeds";
}

}  // namespace
}  // namespace dem
