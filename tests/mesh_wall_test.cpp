// Mesh walls: a triangle mesh as a wall with prescribed motion, against the walls it can
// stand in for (a plane, a solid box), through the World with every stepper and control, and loaded
// from an STL file named by a scene.
#include <gtest/gtest.h>

#include <unistd.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include <Eigen/Geometry>

#include "engine/input_error.h"
#include "engine/scene_loader.h"
#include "engine/walls.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

namespace fs = std::filesystem;
using Triangles = std::vector<std::array<std::uint32_t, 3>>;

/// The box [-h, h] (about the origin) as 12 outward-facing triangles.
std::shared_ptr<const TriangleMesh> box_mesh(const Vec3& h) {
  std::vector<Vec3> p;
  for (int k = 0; k < 8; ++k) p.emplace_back((k & 1 ? 1 : -1) * h.x(), (k & 2 ? 1 : -1) * h.y(), (k & 4 ? 1 : -1) * h.z());
  // Faces as corner quadruples counter-clockwise seen from outside.
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {1, 3, 7, 5}, {0, 4, 6, 2}};
  Triangles t;
  for (const auto& f : q) {
    t.push_back({std::uint32_t(f[0]), std::uint32_t(f[1]), std::uint32_t(f[2])});
    t.push_back({std::uint32_t(f[0]), std::uint32_t(f[2]), std::uint32_t(f[3])});
  }
  return std::make_shared<const TriangleMesh>(p, t);
}

/// The square [-s, s]^2 at z = 0, facing +z, as two triangles sharing the diagonal (-s, -s)-(s, s).
std::shared_ptr<const TriangleMesh> floor_mesh(Real s) {
  return std::make_shared<const TriangleMesh>(std::vector<Vec3>{{-s, -s, 0}, {s, -s, 0}, {s, s, 0}, {-s, s, 0}},
                                              Triangles{{0, 1, 2}, {0, 2, 3}});
}

WallConfig mesh_wall(std::shared_ptr<const TriangleMesh> mesh) {
  WallConfig w;
  w.kind = WallKind::mesh;
  w.mesh = std::move(mesh);
  return w;
}

TEST(MeshWall, MatchesASolidBoxWallAtEveryPoseAndPoint) {
  const Vec3 h(0.5, 0.3, 0.2);
  WallConfig box;
  box.kind = WallKind::box;
  box.inside = false;
  box.half_extents = h;
  WallConfig mesh = mesh_wall(box_mesh(h));
  for (WallConfig* w : {&box, &mesh}) {
    w->point = Vec3(0.3, -0.2, 1.1);
    w->velocity = Vec3(0.1, 0.2, -0.3);
    w->angular_velocity = Vec3(0.4, -1.3, 0.7);
    w->rotation_center = Vec3(-0.5, 0.4, 0.8);
    w->use_rotation_center = true;
    w->ramp_time = 0.5;
  }
  const MaterialTable materials({MaterialConfig{}}, {ContactConfig{}}, Separation::force_zero);
  Walls walls({box, mesh}, materials);
  EXPECT_EQ(walls.feature_count(1), 12u + 18u + 8u);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<Real> u(-1, 1), radius(0.01, 0.3);
  int compared = 0, edges_and_corners = 0;
  for (const Real t : {0.0, 0.3, 1.7}) {
    walls.set_time(t);
    for (int k = 0; k < 3000; ++k) {
      const Vec3 local(0.8 * u(rng), 0.6 * u(rng), 0.5 * u(rng));
      if ((local.cwiseAbs() - h).maxCoeff() <= 0) continue;  // inside the block: the two differ by design
      const Vec3 x = walls.point(0) + walls.rotation(0) * local;
      const Real r = radius(rng);
      WallTouch expected;
      const bool touching = walls.touch(0, 0, x, r, expected);
      ASSERT_EQ(walls.touching_count(1, x, r), touching ? 1u : 0u) << k;
      if (!touching) continue;
      std::uint32_t f = 0;
      WallTouch found;
      walls.touching_features(1, x, r, &f, &found, 1);
      WallTouch got;
      ASSERT_TRUE(walls.touch(1, f, x, r, got));
      EXPECT_EQ(found.overlap, got.overlap);
      EXPECT_EQ(found.normal, got.normal);
      EXPECT_NEAR(got.overlap, expected.overlap, 1e-12);
      EXPECT_LT((got.normal - expected.normal).norm(), 1e-12);
      EXPECT_EQ(walls.velocity_at(0, x), walls.velocity_at(1, x));
      WallTouch other;
      EXPECT_FALSE(walls.touch(1, f == 0 ? 1 : 0, x, r, other));
      ++compared;
      edges_and_corners += walls.mesh(1)->feature_kind(f) != MeshFeatureKind::face ? 1 : 0;
    }
  }
  EXPECT_GT(compared, 1000);
  EXPECT_GT(edges_and_corners, 300);
}

/// A sphere thrown at a floor with spin, bouncing and then rolling; the same run on a plane wall and
/// on the floor as a mesh of two triangles. Returns the trajectory and the wall contacts at each sync.
struct Trajectory {
  std::vector<Vec3> position, angular_velocity;
  std::vector<std::size_t> contacts;
  std::vector<std::uint32_t> feature;
};

Trajectory drop(const WallConfig& floor, Method method, Control control, bool friction, const Vec3& start, const Vec3& velocity) {
  WorldConfig c = test::base_config(2e-4);
  c.integrator.method = method;
  c.integrator.control = control;
  c.integrator.tolerance = 1e-3;
  c.integrator.level_min = -4;
  c.integrator.level_max = 2;  // sync intervals of 4 dt under doubling
  c.model.gravity = Vec3(0, 0, -9.81);
  c.contacts[0].normal_stiffness = 1e5;
  c.contacts[0].normal_damping = {DampingKind::restitution, 0.6};
  if (friction) {
    c.contacts[0].sliding_friction = 0.4;
    c.contacts[0].tangential_damping = {DampingKind::restitution, 0.6};
  }
  c.walls = {floor};
  ParticleConfig p = test::particle(start, velocity, 0.05, 0.5);
  p.angular_velocity = friction ? Vec3(3, -2, 1) : Vec3::Zero();
  c.particles = {p};
  World world(c);
  Trajectory run;
  const int syncs = control == Control::fixed ? 5000 : 1250;  // 1 s
  for (int s = 0; s < syncs; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    run.position.push_back(world.state().position[0]);
    run.angular_velocity.push_back(world.state().angular_velocity[0]);
    run.contacts.push_back(world.wall_contacts().size());
    run.feature.push_back(world.wall_contacts().size() == 1 ? world.wall_contacts().feature[0] : 999);
  }
  return run;
}

TEST(MeshWall, SphereDroppedOnAMeshFloorBouncesLikeOnAPlane) {
  const WallConfig plane = test::plane(Vec3::Zero(), Vec3::UnitZ());
  const WallConfig mesh = mesh_wall(floor_mesh(3));
  struct Case {
    Method method;
    Control control;
    bool friction;
  };
  for (const Case k : {Case{Method::verlet, Control::fixed, false}, Case{Method::verlet, Control::fixed, true},
                       Case{Method::exact, Control::fixed, false}, Case{Method::exact, Control::fixed, true},
                       Case{Method::verlet, Control::doubling, false}, Case{Method::verlet, Control::doubling, true}}) {
    SCOPED_TRACE(::testing::Message() << "method " << int(k.method) << " control " << int(k.control) << " friction "
                                      << k.friction);
    const Vec3 start(-0.4, -0.1, 0.2), velocity(0.6, 0.05, -0.5);
    const Trajectory a = drop(plane, k.method, k.control, k.friction, start, velocity);
    const Trajectory b = drop(mesh, k.method, k.control, k.friction, start, velocity);
    ASSERT_EQ(a.position.size(), b.position.size());
    std::size_t touching = 0;
    for (std::size_t s = 0; s < a.position.size(); ++s) {
      ASSERT_EQ(a.position[s], b.position[s]) << "sync " << s;
      ASSERT_EQ(a.angular_velocity[s], b.angular_velocity[s]) << "sync " << s;
      ASSERT_EQ(a.contacts[s], b.contacts[s]) << "sync " << s;
      touching += b.contacts[s];
    }
    EXPECT_GT(touching, 100u);  // it bounced and came to rest on the floor
    EXPECT_GT(b.position.back().x(), b.position.back().y());  // crossing the shared edge (the diagonal x = y)
    EXPECT_NEAR(b.position.back().z(), 0.05, 1e-3);
  }
}

TEST(MeshWall, SphereRollingAcrossTheSharedEdgeKeepsOneContactAllAlong) {
  // Rolling along x with friction, crossing the diagonal x = y of the two-triangle floor near (0.2, 0.2).
  const WallConfig plane = test::plane(Vec3::Zero(), Vec3::UnitZ());
  const WallConfig mesh = mesh_wall(floor_mesh(3));
  const Vec3 start(-0.3, 0.2, 0.05 - 0.5 * 9.81 / 1e5);  // resting depth m g / k
  const Trajectory a = drop(plane, Method::verlet, Control::fixed, true, start, Vec3(1, 0, 0));
  const Trajectory b = drop(mesh, Method::verlet, Control::fixed, true, start, Vec3(1, 0, 0));
  bool crossed = false;
  for (std::size_t s = 0; s < b.position.size(); ++s) {
    ASSERT_EQ(b.contacts[s], 1u) << "sync " << s;
    ASSERT_EQ(b.feature[s], 0u) << "one facet, one key, history kept: sync " << s;
    ASSERT_EQ(a.position[s], b.position[s]) << "sync " << s;
    crossed = crossed || b.position[s].x() > b.position[s].y() + 0.05;
  }
  EXPECT_TRUE(crossed);
}

/// Many spheres raining on a bumpy mesh of thousands of triangles: the same state for any thread count.
TEST(MeshWall, BumpyMeshGivesOneStateForAnyThreadCount) {
  const int n = 48;  // 4608 triangles
  std::vector<Vec3> p;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const Real x = -1 + 2.0 * i / n, y = -1 + 2.0 * j / n;
      p.emplace_back(x, y, 0.04 * std::sin(7 * x) * std::cos(5 * y) + 0.1 * (x * x + y * y));
    }
  Triangles t;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const auto id = [&](int a, int b) { return std::uint32_t(b * (n + 1) + a); };
      t.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      t.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  WorldConfig c = test::base_config(1e-4);
  c.model.gravity = Vec3(0, 0, -9.81);
  c.contacts[0].normal_stiffness = 2e4;
  c.contacts[0].normal_damping = {DampingKind::restitution, 0.5};
  c.contacts[0].sliding_friction = 0.3;
  c.walls = {mesh_wall(std::make_shared<const TriangleMesh>(p, t))};
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<Real> u(-0.8, 0.8);
  for (int k = 0; k < 300; ++k) {
    const Vec3 x(u(rng), u(rng), 0.35 + 0.05 * (k / 60));
    bool free = true;
    for (const ParticleConfig& q : c.particles) free = free && (q.position - x).norm() > 0.05;
    if (free) c.particles.push_back(test::particle(x, Vec3::Zero(), 0.02, 0.01));
  }
  ASSERT_GT(c.particles.size(), 150u);
  const test::AllowThreads allow(3);  // oversubscribed on 2 cores
  std::uint64_t hash = 0;
  std::size_t contacts = 0;
  for (const int threads : {1, 2, 3}) {
    c.threads = threads;
    World world(c);
    EXPECT_EQ(world.arena().max_concurrency(), threads);
    for (int s = 0; s < 6000; ++s) ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
    if (threads == 1) {
      hash = world.state_hash();
      contacts = world.wall_contacts().size();
    }
    EXPECT_EQ(world.state_hash(), hash) << threads << " threads";
  }
  EXPECT_GT(contacts, 50u);  // most have landed on the mesh
}

// ---- from an STL file named by a scene ---------------------------------------------------------

void put_u32(std::string& out, std::uint32_t v) {
  for (int k = 0; k < 4; ++k) out.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
}

/// A binary STL of the floor [-s, s]^2 at z = 0 (coordinates in the file's units).
std::string floor_stl(float s) {
  std::string out(80, ' ');
  put_u32(out, 2);
  const float corner[4][3] = {{-s, -s, 0}, {s, -s, 0}, {s, s, 0}, {-s, s, 0}};
  for (const auto& tri : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
    for (int k = 0; k < 3; ++k) put_u32(out, 0);
    for (const int v : tri)
      for (int a = 0; a < 3; ++a) put_u32(out, std::bit_cast<std::uint32_t>(corner[v][a]));
    out.append(2, '\0');
  }
  return out;
}

TEST(MeshWall, SceneReadsAnStlInMillimetresRelativeToTheSceneFile) {
  const fs::path dir = fs::temp_directory_path() / ("dem_mesh_wall_test_" + std::to_string(::getpid()));
  fs::create_directories(dir / "parts");
  std::ofstream(dir / "parts" / "floor.stl", std::ios::binary) << floor_stl(3000);
  const std::string common = R"(
[scene]
gravity = [0, 0, -9.81]
[[contacts]]
normal_stiffness = 1e5
normal_damping = { restitution = 0.6 }
[integrator]
dt = 2e-4
[[particles]]
position = [-0.4, -0.1, 0.2]
velocity = [0.6, 0.05, -0.5]
radius = 0.05
mass = 0.5
)";
  const std::string mesh_scene = common + R"(
[[walls]]
name = "liner"
type = "mesh"
file = "parts/floor.stl"
scale = 0.001
point = [0, 0, -0.25]
velocity = [0, 0, 0]
)";
  const std::string plane_scene = common + R"(
[[walls]]
type = "plane"
point = [0, 0, -0.25]
)";
  const Scene with_mesh = load_scene_text(mesh_scene, (dir / "mesh.toml").string(), dir.string(), {});
  ASSERT_EQ(with_mesh.world.walls.size(), 1u);
  const WallConfig& w = with_mesh.world.walls[0];
  EXPECT_EQ(w.kind, WallKind::mesh);
  EXPECT_EQ(w.scale, 0.001);
  ASSERT_TRUE(w.mesh);
  EXPECT_EQ(w.mesh->triangle_count(), 2u);
  EXPECT_EQ(w.mesh->upper(), Vec3(3, 3, 0));
  const Scene with_plane = load_scene_text(plane_scene, (dir / "plane.toml").string(), dir.string(), {});
  World a(with_plane.world), b(with_mesh.world);
  for (int s = 0; s < 6000; ++s) {
    ASSERT_EQ(a.advance_sync_interval(), StepStatus::ok);
    ASSERT_EQ(b.advance_sync_interval(), StepStatus::ok);
    ASSERT_EQ(a.state().position[0], b.state().position[0]) << s;
  }
  EXPECT_NEAR(b.state().position[0].z(), -0.2, 1e-3);
  // The mesh is part of the physics: another STL gives another hash.
  std::ofstream(dir / "parts" / "floor.stl", std::ios::binary) << floor_stl(2999);
  EXPECT_NE(load_scene_text(mesh_scene, (dir / "mesh.toml").string(), dir.string(), {}).physics_hash,
            with_mesh.physics_hash);
  // Keys of other wall types are unknown on a mesh.
  EXPECT_THROW(load_scene_text(mesh_scene + "normal = [0, 0, 1]\n", (dir / "mesh.toml").string(), dir.string(), {}),
               InputError);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace dem
