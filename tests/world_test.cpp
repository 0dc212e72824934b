// World-level contracts an embedding program relies on: immovable particles (infinite mass) never
// produce NaN, even touching each other or a wall, and a configuration a run cannot survive is
// refused at construction.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "engine/world.h"
#include "tests/contact_scenes.h"

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

}  // namespace
}  // namespace dem
