// The wall broadphase (wall_lists.h): while the lists report themselves valid, no wall left out of a
// particle's list touches it, for prisms that turn about an off-axis centre, translate and ramp up,
// and planes, boxes and cylinders at rest or translating; a list holds exactly the walls within the
// margin, for up to 64 walls and for more; a mill and a box of particles run to the same state with
// the lists as without them, levels per particle included; lists selected for some particles are
// their rows; collision anticipation finds the walls that testing each would.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "engine/island_stepper.h"
#include "engine/scene_loader.h"
#include "engine/wall_lists.h"
#include "engine/world.h"
#include "tests/mill_scenes.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

MaterialTable one_material() { return MaterialTable({MaterialConfig{}}, {ContactConfig{}}, Separation::force_zero); }

/// A bar of rectangular cross-section 2 a x 2 b about `centre`, axis z, of length 2 c.
WallConfig bar(const Vec3& centre, Real a, Real b, Real c) {
  WallConfig w;
  w.kind = WallKind::prism;
  w.point = centre;
  w.axis = Vec3::UnitZ();
  w.length = 2 * c;
  for (const auto& [x, y] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) w.profile.push_back(centre + Vec3(x * a, y * b, 0));
  w.use_rotation_center = true;  // the origin, as a lifter turns about the mill's axis
  return w;
}

bool listed(const WallLists& lists, std::size_t p, std::size_t w) {
  for (std::uint32_t k = lists.row_start(p); k < lists.row_start(p + 1); ++k)
    if (lists.wall(k) == w) return true;
  return false;
}

/// Two lifter-like bars turning with a ramp about the origin (one of them also translating), a
/// plane below, a container box, a translating solid block, a translating cylinder, a shell and an
/// end plane turning in place (a mill's: filtered) and, last, an eccentric turning drum (never filtered).
std::vector<WallConfig> varied_walls() {
  std::vector<WallConfig> config;
  config.push_back(bar(Vec3(0.1, 0, 0), 0.01, 0.006, 0.05));
  config.back().angular_velocity = Vec3(0, 0, 6);
  config.back().ramp_time = 0.2;
  config.push_back(bar(Vec3(-0.08, 0.03, 0), 0.008, 0.01, 0.05));
  config.back().angular_velocity = Vec3(0, 0, -4);
  config.back().velocity = Vec3(0.3, 0, 0);
  WallConfig floor;
  floor.kind = WallKind::plane;
  floor.point = Vec3(0, -0.12, 0);
  floor.normal = Vec3::UnitY();
  config.push_back(floor);
  WallConfig container;
  container.kind = WallKind::box;
  container.half_extents = Vec3(0.12, 0.12, 0.03);
  config.push_back(container);
  WallConfig block;
  block.kind = WallKind::box;
  block.inside = false;
  block.point = Vec3(0.05, -0.06, 0);
  block.half_extents = Vec3(0.02, 0.01, 0.05);
  block.velocity = Vec3(0, 0.2, 0);
  config.push_back(block);
  WallConfig drum;
  drum.kind = WallKind::cylinder;
  drum.axis = Vec3::UnitZ();
  drum.radius = 0.11;
  drum.length = 0.1;
  drum.velocity = Vec3(0.1, 0, 0);
  config.push_back(drum);
  WallConfig shell = drum;
  shell.velocity = Vec3::Zero();
  shell.radius = 0.12;
  shell.angular_velocity = Vec3(0, 0, 3);
  config.push_back(shell);
  WallConfig end;
  end.kind = WallKind::plane;
  end.point = Vec3(0, 0, 0.015);
  end.normal = -Vec3::UnitZ();
  end.angular_velocity = Vec3(0, 0, 3);
  end.rotation_center = Vec3::Zero();  // off the plane, as a mill's end walls turn about its axis
  end.use_rotation_center = true;
  config.push_back(end);
  WallConfig eccentric = shell;
  eccentric.radius = 0.115;
  eccentric.point = Vec3(0.01, 0, 0);
  eccentric.rotation_center = Vec3::Zero();
  eccentric.use_rotation_center = true;
  config.push_back(eccentric);
  return config;
}

TEST(WallLists, NoWallLeftOutTouchesWhileTheListsAreValid) {
  const std::vector<WallConfig> config = varied_walls();
  const std::size_t turning = config.size() - 1;
  Walls walls(config, one_material());
  for (std::size_t w = 0; w < turning; ++w)
    ASSERT_TRUE(walls.filtered(w)) << "wall " << w << " moves without turning, or turns in place";
  ASSERT_FALSE(walls.filtered(turning)) << "an eccentric turning drum sweeps space: it is never filtered";
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<Real> u(-1, 1);
  State s;
  const int n = 2000;
  for (int p = 0; p < n; ++p)
    s.add(Vec3(0.13 * u(rng), 0.13 * u(rng), 0.02 * u(rng)), Vec3::Zero(), Vec3::Zero(), 0.004 + 0.002 * u(rng), 1, 1, 0);
  s.add(Vec3(0.1, 0.02, 0), Vec3::Zero(), Vec3::Zero(), 0.004, 0, 0, 0);  // immovable: no list
  const Real margin = 0.003;
  const State start = s;
  int valid_trials = 0, touches_checked = 0, filtered_out = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const Real t0 = 0.05 + 0.5 * std::abs(u(rng));
    walls.set_time(t0);
    s = start;
    WallLists lists;
    lists.build(s, walls, margin);
    EXPECT_EQ(lists.row_start(s.size() - 1), lists.row_start(s.size())) << "an immovable particle lists no wall";
    for (std::size_t p = 0; p + 1 < s.size(); ++p) {
      EXPECT_TRUE(listed(lists, p, turning)) << "an eccentric turning drum is never filtered";
      filtered_out += !listed(lists, p, 0) + !listed(lists, p, 1);
    }
    // Move walls and particles by random amounts, some beyond what the lists allow.
    walls.set_time(t0 + 6e-3 * std::abs(u(rng)));  // bar travel up to about 4 mm
    const Real reach = margin * 0.6 * std::abs(u(rng));
    for (std::size_t p = 0; p + 1 < s.size(); ++p) {
      const Vec3 d(u(rng), u(rng), u(rng));
      s.position[p] += reach * std::abs(u(rng)) * d.normalized();
    }
    if (!lists.valid(s, walls)) continue;
    ++valid_trials;
    for (std::size_t p = 0; p + 1 < s.size(); ++p)
      for (std::size_t w = 0; w < walls.count(); ++w) {
        if (walls.touching_count(w, s.position[p], s.radius[p]) == 0) continue;
        ++touches_checked;
        EXPECT_TRUE(listed(lists, p, w)) << "trial " << trial << ": particle " << p << " touches wall " << w
                                         << " but was left out of its list";
      }
  }
  EXPECT_GT(valid_trials, 40);
  EXPECT_LT(valid_trials, 190) << "some trials move beyond the margin: valid() must say so";
  EXPECT_GT(touches_checked, 2000);
  EXPECT_GT(filtered_out, 200 * n) << "most particles are far from most bars: the lists leave those out";
}

// A particle's list holds exactly the walls Walls::may_touch accepts within the margin, ascending,
// whether the walls fit the builder's bit masks (up to 64) or not: a ring of 60 bars, then 70.
TEST(WallLists, EachListHoldsExactlyTheWallsWithinTheMarginForAnyNumberOfWalls) {
  for (const std::size_t count : {std::size_t{60}, std::size_t{70}}) {
    std::vector<WallConfig> config;
    for (std::size_t w = 0; w < count; ++w) {
      const Real angle = 2 * std::acos(-1.0) * static_cast<Real>(w) / static_cast<Real>(count);
      config.push_back(bar(0.1 * Vec3(std::cos(angle), std::sin(angle), 0), 0.004, 0.003, 0.05));
    }
    const Walls walls(config, one_material());
    std::mt19937_64 rng(count);
    std::uniform_real_distribution<Real> u(-1, 1);
    State s;
    for (int p = 0; p < 3000; ++p)
      s.add(Vec3(0.11 * u(rng), 0.11 * u(rng), 0.02 * u(rng)), Vec3::Zero(), Vec3::Zero(), 0.004, 1, 1, 0);
    const Real margin = 0.004;
    WallLists lists;
    lists.build(s, walls, margin);
    std::size_t entries = 0, most = 0;
    for (std::size_t p = 0; p < s.size(); ++p) {
      std::vector<std::uint16_t> expected;
      for (std::size_t w = 0; w < count; ++w)
        if (walls.may_touch(w, s.position[p], s.radius[p], margin)) expected.push_back(static_cast<std::uint16_t>(w));
      std::vector<std::uint16_t> got;
      for (std::uint32_t k = lists.row_start(p); k < lists.row_start(p + 1); ++k) got.push_back(lists.wall(k));
      ASSERT_EQ(got, expected) << count << " walls, particle " << p;
      entries += got.size();
      most = std::max(most, got.size());
    }
    EXPECT_GT(entries, 100u) << count << " walls: particles near the ring list some bars";
    EXPECT_GE(most, 2u) << count << " walls: some particle lists neighbouring bars";
  }
}

TEST(WallLists, ListsSelectedForSomeParticlesAreTheirRowsWithTheSameValidity) {
  std::vector<WallConfig> config;
  for (int w = 0; w < 12; ++w) {
    const Real angle = 2 * std::acos(-1.0) * w / 12.0;
    config.push_back(bar(0.1 * Vec3(std::cos(angle), std::sin(angle), 0), 0.004, 0.003, 0.05));
  }
  const Walls walls(config, one_material());
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<Real> u(-1, 1);
  State s;
  for (int p = 0; p < 400; ++p)
    s.add(Vec3(0.11 * u(rng), 0.11 * u(rng), 0.02 * u(rng)), Vec3::Zero(), Vec3::Zero(), 0.004, p % 50 == 0 ? 0 : 1, 1, 0);
  const Real margin = 0.004;
  WallLists parent;
  parent.build(s, walls, margin);
  // Every third particle, last first, as a group of its own.
  std::vector<std::uint32_t> members;
  for (int p = 399; p >= 0; p -= 3) members.push_back(static_cast<std::uint32_t>(p));
  WallLists selected;
  selected.select(parent, members);
  State sub;
  select_particles(s, members, sub);
  std::size_t entries = 0;
  std::vector<std::uint32_t> listed;
  for (std::size_t q = 0; q < members.size(); ++q) {
    std::vector<std::uint16_t> expected, got;
    for (std::uint32_t k = parent.row_start(members[q]); k < parent.row_start(members[q] + 1); ++k)
      expected.push_back(parent.wall(k));
    for (std::uint32_t k = selected.row_start(q); k < selected.row_start(q + 1); ++k) got.push_back(selected.wall(k));
    ASSERT_EQ(got, expected) << "member " << q;
    if (!got.empty()) listed.push_back(static_cast<std::uint32_t>(q));
    entries += got.size();
  }
  EXPECT_GT(entries, 10u) << "some members list bars";
  EXPECT_EQ(selected.listed_particles(), listed);
  EXPECT_EQ(selected.particle_count(), members.size());
  EXPECT_TRUE(selected.valid(sub, walls));
  sub.position[5].x() += 1.01 * margin;  // measured from where the parent's build had it
  EXPECT_FALSE(selected.valid(sub, walls));
  WallLists unbuilt;
  selected.select(unbuilt, members);
  EXPECT_FALSE(selected.valid(sub, walls)) << "lists selected from unbuilt ones are not valid";
}

TEST(WallLists, ValidityFollowsTheMarginLessTheWallsTravel) {
  std::vector<WallConfig> config{bar(Vec3(0.1, 0, 0), 0.01, 0.006, 0.05)};
  config[0].angular_velocity = Vec3(0, 0, 2);  // no ramp: the far corner moves at 2 * reach m/s
  Walls walls(config, one_material());
  State s;
  s.add(Vec3(0, 0.05, 0), Vec3::Zero(), Vec3::Zero(), 0.004, 1, 1, 0);
  WallLists lists;
  lists.build(s, walls, 1e-3);
  EXPECT_TRUE(lists.valid(s, walls));
  s.position[0].x() += 0.999e-3;
  EXPECT_TRUE(lists.valid(s, walls));
  s.position[0].x() += 2e-6;
  EXPECT_FALSE(lists.valid(s, walls)) << "moved beyond the margin";
  s.position[0].x() -= 0.5e-3;  // about 0.5 mm moved: room for 0.5 mm of wall travel
  const Real reach = std::hypot(0.11, 0.006);  // the far corner from the rotation axis (z, through 0)
  walls.set_time(0.45e-3 / (2 * reach));
  EXPECT_TRUE(lists.valid(s, walls));
  walls.set_time(0.55e-3 / (2 * reach));
  EXPECT_FALSE(lists.valid(s, walls)) << "the walls' travel counts against the margin";
  s.add(Vec3(0, 0.06, 0), Vec3::Zero(), Vec3::Zero(), 0.004, 1, 1, 0);
  EXPECT_FALSE(lists.valid(s, walls)) << "another particle count";
}

TEST(WallLists, AMillRunsToTheSameStateWithAndWithoutThem) {
  // The fixed step with each stepper, and levels per particle (whose trials select their levels'
  // lists from their island's).
  const std::vector<std::vector<std::string>> runs = {
      {},
      {"integrator.method=\"exact\"", "contacts[0].sliding_friction=0.0", "contacts[0].rolling_friction=0.0"},
      {"integrator.control=\"doubling\"", "integrator.tolerance=0.1", "integrator.particle_levels=true"}};
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const std::vector<std::string>& overrides = runs[r];
    SCOPED_TRACE(r == 0 ? "verlet" : r == 1 ? "exact" : "levels per particle");
    std::uint64_t hash[2];
    std::size_t wall_bytes[2];
    for (int with : {0, 1}) {
      std::vector<std::string> o = overrides;
      o.push_back(with ? "broadphase.wall_lists=true" : "broadphase.wall_lists=false");
      const Scene scene = load_scene_text(test::mill_scene(8, 0.75, "count = 60"), "mill.toml", ".", o);
      World world(scene.world);
      ASSERT_EQ(world.run_until(0.35), StepStatus::ok);
      hash[with] = world.state_hash();
      wall_bytes[with] = 0;
      for (const MemoryPart& part : world.memory_breakdown())
        if (part.name == std::string("wall lists")) wall_bytes[with] = part.bytes;
    }
    EXPECT_EQ(hash[0], hash[1]) << "the lists must only skip tests that could not succeed";
    EXPECT_EQ(wall_bytes[0], 0u);
    EXPECT_GT(wall_bytes[1], 0u) << "the run with lists must have used them";
  }
}

TEST(WallLists, ParticlesFallingInABoxRunToTheSameStateWithAndWithoutThem) {
  for (const Method method : {Method::verlet, Method::exact}) {
    SCOPED_TRACE(method == Method::verlet ? "verlet" : "exact");
    std::uint64_t hash[2];
    std::size_t wall_contacts[2];
    for (const bool with : {false, true}) {
      WorldConfig c = test::falling_box_scene(6, 6, 6, 5);
      c.integrator.method = method;
      if (method == Method::exact) c.contacts[0].sliding_friction = c.contacts[0].rolling_friction = 0;
      c.broadphase.wall_lists = with;
      World world(c);
      std::size_t most = 0;
      for (int i = 0; i < 1500; ++i) {
        ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
        most = std::max(most, world.wall_contacts().size());
      }
      hash[with] = world.state_hash();
      wall_contacts[with] = most;
    }
    EXPECT_EQ(hash[0], hash[1]) << "the lists must only skip tests that could not succeed";
    EXPECT_GT(wall_contacts[1], 10u) << "the particles must have reached the box's faces";
  }
}

// Collision anticipation passes over the walls a particle is too far from to reach within a step
// (ClosingWalls, island_stepper.h); it must find exactly the walls that testing each with
// wall_may_close finds: particles moving and accelerating at random among turning, ramping and
// translating walls, at steps from 10 us to 10 ms, and beside a particle whose position or velocity
// is not finite (then the bound is not either, and every wall is tested).
std::vector<std::size_t> walls_testing_each(const State& s, const Walls& walls, std::size_t a, const Vec3& gravity,
                                            Real h) {
  std::vector<std::size_t> found;
  for (std::size_t w = 0; w < walls.count(); ++w)
    if (wall_may_close(s, a, walls, w, gravity, h)) found.push_back(w);
  return found;
}

std::vector<std::size_t> walls_closing(const ClosingWalls& closing, std::size_t a, Real h) {
  std::vector<std::size_t> found;
  EXPECT_TRUE(closing.for_each(a, h, [&](std::size_t w) {
    found.push_back(w);
    return true;
  }));
  return found;
}

TEST(WallLists, ClosingWallsFindsTheWallsThatTestingEachFinds) {
  Walls walls(varied_walls(), one_material());
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<Real> u(-1, 1);
  State s;
  for (int p = 0; p < 1000; ++p) {
    s.add(Vec3(0.13 * u(rng), 0.13 * u(rng), 0.02 * u(rng)), Vec3(u(rng), u(rng), u(rng)), Vec3::Zero(),
          0.004 + 0.002 * u(rng), 1, 1, 0);
    s.force.back() = 20 * Vec3(u(rng), u(rng), u(rng));
  }
  s.add(Vec3(0.1, 0.02, 0), Vec3(1, 0, 0), Vec3::Zero(), 0.004, 0, 0, 0);  // immovable: closes on nothing
  const Vec3 gravity(0, -9.81, 0);
  int closing = 0, far = 0;
  for (Real t : {0.0, 0.1, 0.7}) {
    walls.set_time(t);
    const ClosingWalls found(s, walls, gravity);
    for (Real h : {1e-5, 1e-4, 1e-3, 1e-2})
      for (std::size_t a = 0; a < s.size(); ++a) {
        const std::vector<std::size_t> expected = walls_testing_each(s, walls, a, gravity, h);
        ASSERT_EQ(walls_closing(found, a, h), expected) << "t = " << t << " s, h = " << h << " s, particle " << a;
        closing += static_cast<int>(expected.size());
        for (std::size_t w = 0; w < walls.count(); ++w)
          far += walls.filtered(w) && !walls.may_touch(w, s.position[a], s.radius[a], 0.01);
      }
  }
  EXPECT_GT(closing, 500) << "the particles must close on some walls for the comparison to mean anything";
  EXPECT_GT(far, 10000) << "and most must be far from most walls, which the filter passes over";
  // Stopping: for_each reports that visit stopped it.
  walls.set_time(0.1);
  const ClosingWalls found(s, walls, gravity);
  for (std::size_t a = 0; a < s.size(); ++a)
    EXPECT_EQ(found.for_each(a, 1e-2, [](std::size_t) { return false; }),
              walls_testing_each(s, walls, a, gravity, 1e-2).empty());
  // A particle at an infinite or NaN position, or with a NaN velocity, first or last among the others.
  const Real inf = std::numeric_limits<Real>::infinity(), nan = std::numeric_limits<Real>::quiet_NaN();
  for (const auto& [x, v] : {std::pair{Vec3(inf, 0, 0), Vec3(0, 0, 0)}, std::pair{Vec3(0.1, nan, 0), Vec3(0, 0, 0)},
                             std::pair{Vec3(0.1, 0.1, 0), Vec3(nan, 0, 0)}}) {
    for (bool first : {true, false}) {
      State odd;
      if (first) odd.add(x, v, Vec3::Zero(), 0.004, 1, 1, 0);
      for (std::size_t p = 0; p < s.size(); ++p) {
        odd.add(s.position[p], s.velocity[p], s.angular_velocity[p], s.radius[p], s.inv_mass[p], s.inv_inertia[p], 0);
        odd.force.back() = s.force[p];
      }
      if (!first) odd.add(x, v, Vec3::Zero(), 0.004, 1, 1, 0);
      const ClosingWalls with_odd(odd, walls, gravity);
      for (std::size_t a = 0; a < odd.size(); ++a)
        ASSERT_EQ(walls_closing(with_odd, a, 1e-3), walls_testing_each(odd, walls, a, gravity, 1e-3))
            << "particle " << a << " beside one at " << x.transpose() << " moving at " << v.transpose();
    }
  }
}

}  // namespace
}  // namespace dem
