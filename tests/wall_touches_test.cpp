// Wall contacts found once per step: Walls::touching_features gives each touched feature the very
// geometry touch() gives it (bit for bit) for every kind of wall, and counts past the room it is
// given; update_wall_contacts lists exactly the touching features of a brute-force search, each with
// touch()'s geometry in work.wall_touch, for particles with more touches than its counting pass keeps
// (a corner of a box) as for those with fewer, with the wall lists (which skip immovable particles)
// and without.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <memory>
#include <random>

#include <Eigen/Geometry>

#include "engine/contacts.h"
#include "engine/triangle_mesh.h"
#include "engine/wall_lists.h"
#include "engine/walls.h"

namespace dem {
namespace {

MaterialTable one_material() { return MaterialTable({MaterialConfig{}}, {ContactConfig{}}, Separation::force_zero); }

/// A container box turned about z, a solid block, a floor, a drum, a triangular bar and a mesh, all moving.
std::vector<WallConfig> walls_of_every_kind() {
  std::vector<WallConfig> config;
  WallConfig container;
  container.kind = WallKind::box;
  container.half_extents = Vec3(0.1, 0.08, 0.06);
  container.angular_velocity = Vec3(0, 0, 0.7);
  config.push_back(container);
  WallConfig block;
  block.kind = WallKind::box;
  block.inside = false;
  block.point = Vec3(0.03, -0.02, 0);
  block.half_extents = Vec3(0.02, 0.01, 0.03);
  block.velocity = Vec3(0, 0.2, 0.1);
  config.push_back(block);
  WallConfig floor;
  floor.kind = WallKind::plane;
  floor.point = Vec3(0, -0.07, 0);
  floor.normal = Vec3(0.1, 1, 0).normalized();
  config.push_back(floor);
  WallConfig drum;
  drum.kind = WallKind::cylinder;
  drum.axis = Vec3::UnitZ();
  drum.radius = 0.09;
  drum.length = 0.1;
  drum.angular_velocity = Vec3(0, 0, 2);
  config.push_back(drum);
  WallConfig bar;
  bar.kind = WallKind::prism;
  bar.point = Vec3(-0.04, 0.03, 0);
  bar.axis = Vec3::UnitZ();
  bar.length = 0.08;
  bar.profile = {Vec3(-0.05, 0.02, 0), Vec3(-0.03, 0.02, 0), Vec3(-0.04, 0.045, 0)};
  bar.angular_velocity = Vec3(0, 0, 3);
  bar.use_rotation_center = true;
  config.push_back(bar);
  // A square of two triangles facing +y, tilted and turning: faces, edges and corners.
  WallConfig mesh;
  mesh.kind = WallKind::mesh;
  mesh.mesh = std::make_shared<const TriangleMesh>(
      std::vector<Vec3>{{-0.04, 0, -0.04}, {0.04, 0, -0.04}, {0.04, 0.01, 0.04}, {-0.04, 0.01, 0.04}},
      std::vector<std::array<std::uint32_t, 3>>{{0, 2, 1}, {0, 3, 2}});
  mesh.point = Vec3(0.02, 0.04, 0);
  mesh.angular_velocity = Vec3(0.5, 0, 1);
  config.push_back(mesh);
  return config;
}

std::uint32_t features_of(const Walls& walls, std::size_t w) { return walls.feature_count(w); }

TEST(WallTouches, EachFeatureGetsTouchsGeometryBitForBitAndTheCountGoesPastTheRoom) {
  Walls walls(walls_of_every_kind(), one_material());
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<Real> u(-0.11, 0.11), radius(0.002, 0.03);
  std::size_t touched = 0, several = 0, meshes = 0;
  for (const Real t : {0.0, 0.4}) {
    walls.set_time(t);
    for (int k = 0; k < 4000; ++k) {
      const Vec3 x(u(rng), u(rng), 0.6 * u(rng));
      const Real r = radius(rng);
      for (std::size_t w = 0; w < walls.count(); ++w) {
        std::vector<std::uint32_t> expected;
        std::vector<WallTouch> geometry;
        for (std::uint32_t f = 0; f < features_of(walls, w); ++f) {
          WallTouch g;
          if (walls.touch(w, f, x, r, g)) expected.push_back(f), geometry.push_back(g);
        }
        constexpr std::uint32_t room = 16;
        std::uint32_t features[room];
        WallTouch touches[room];
        const std::uint32_t count = walls.touching_features(w, x, r, features, touches, room);
        ASSERT_EQ(count, expected.size()) << "wall " << w << ", sphere " << k;
        ASSERT_LE(count, room);
        ASSERT_EQ(walls.touching_count(w, x, r), count);
        for (std::uint32_t q = 0; q < count; ++q) {
          EXPECT_EQ(features[q], expected[q]);
          EXPECT_EQ(touches[q].overlap, geometry[q].overlap);  // exact: the force loop reads these
          EXPECT_EQ(touches[q].normal, geometry[q].normal);
        }
        touched += count > 0;
        meshes += walls.config(w).kind == WallKind::mesh && count > 0;
        if (count < 2) continue;
        ++several;
        // Room for one: the first is written, the rest only counted.
        std::uint32_t room_for_one[2] = {99, 99};
        WallTouch one[2];
        one[1].overlap = -1;
        EXPECT_EQ(walls.touching_features(w, x, r, room_for_one, one, 1), count);
        EXPECT_EQ(room_for_one[0], expected[0]);
        EXPECT_EQ(one[0].overlap, geometry[0].overlap);
        EXPECT_EQ(room_for_one[1], 99u);
        EXPECT_EQ(one[1].overlap, -1);
      }
    }
  }
  EXPECT_GT(touched, 2000u);
  EXPECT_GT(several, 100u) << "spheres in the container's edges and corners";
  EXPECT_GT(meshes, 50u);
}

TEST(WallTouches, TheContactListAndItsGeometryMatchABruteForceSearchWithAndWithoutLists) {
  Walls walls(walls_of_every_kind(), one_material());
  walls.set_time(0.3);
  State s;
  std::mt19937_64 rng(8);
  std::uniform_real_distribution<Real> u(-0.1, 0.1);
  // A sphere in a corner of the container (three faces, more than the counting pass keeps), one on
  // an edge (two), then random ones.
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(walls.config(0).angular_velocity.z() * 0.3, Vec3::UnitZ()).matrix();
  ASSERT_EQ(walls.config(0).ramp_time, 0);
  s.add(turn * Vec3(0.095, 0.075, 0.055), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(turn * Vec3(-0.095, 0.0, -0.055), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  // Every fifth immovable: walls leave it alone, so the lists visit fewer particles than there are.
  for (int k = 0; k < 600; ++k) {
    const Real inv = k % 5 == 4 ? 0 : 1;
    s.add(Vec3(u(rng), u(rng), 0.6 * u(rng)), Vec3::Zero(), Vec3::Zero(), 0.012, inv, inv, 0);
  }
  std::vector<std::uint64_t> expected_keys;
  std::vector<WallTouch> expected_geometry;
  for (std::size_t p = 0; p < s.size(); ++p)
    for (std::size_t w = 0; w < walls.count() && s.inv_mass[p] > 0; ++w)
      for (std::uint32_t f = 0; f < features_of(walls, w); ++f) {
        WallTouch g;
        if (!walls.touch(w, f, s.position[p], s.radius[p], g)) continue;
        expected_keys.push_back(wall_key(s.id[p], static_cast<std::uint32_t>(w), f));
        expected_geometry.push_back(g);
      }
  const auto of_first = [&](std::uint64_t key) { return key >> 32 == s.id[0]; };
  ASSERT_GE(std::count_if(expected_keys.begin(), expected_keys.end(), of_first), 3);
  WallLists lists;
  lists.build(s, walls, 0.005);
  ASSERT_LT(lists.listed_particles().size(), s.size() - 100);
  const MaterialTable materials = one_material();
  for (const WallLists* l : {static_cast<const WallLists*>(nullptr), static_cast<const WallLists*>(&lists)}) {
    WallContacts contacts;
    ContactWorkspace work;
    std::vector<std::uint32_t> wall_start;
    update_wall_contacts(s, walls, materials, contacts, work, wall_start, l);
    ASSERT_EQ(contacts.key, expected_keys) << (l ? "with lists" : "without lists");
    ASSERT_EQ(work.wall_touch.size(), contacts.size());
    for (std::size_t k = 0; k < contacts.size(); ++k) {
      EXPECT_EQ(work.wall_touch[k].overlap, expected_geometry[k].overlap) << k;
      EXPECT_EQ(work.wall_touch[k].normal, expected_geometry[k].normal) << k;
      EXPECT_EQ(contacts.particle[k], s.index_of_id[contacts.key[k] >> 32]);
    }
  }
}

}  // namespace
}  // namespace dem
