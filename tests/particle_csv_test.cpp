// Particle CSV files (engine/particle_csv.h) and the ids, masses and materials they give a scene:
//  - what is written reads back as the same doubles, ids, masses, densities and materials, and
//    writing what was read gives the same bytes;
//  - the reader honours id, mass, density (per row, an empty cell meaning "not given") and material
//    columns in any order;
//  - a scene numbers its particles by the ids its files give, the others after the largest, and a
//    World built from it holds each particle under its id with the mass its row gave;
//  - World::particles() rebuilds a world with the same ids, masses, inertias and radii bit for bit.
// The bad-input messages (repeated and negative ids, both mass and density, unknown material) are in
// the corpus of tests/scenes/bad/ (cli_test).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

#include "engine/input_error.h"
#include "engine/materials.h"
#include "engine/particle_csv.h"
#include "engine/scene.h"
#include "engine/scene_loader.h"
#include "engine/world.h"

namespace dem {
namespace {

namespace fs = std::filesystem;

class ParticleCsv : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("dem_particle_csv_" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(dir_ / name, std::ios::binary) << text;
    return (dir_ / name).string();
  }
  static std::string read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  fs::path dir_;
};

// Doubles that a short decimal would not carry: thirds, sevenths, tiny, huge, subnormal, negative zero.
std::vector<ParticleConfig> awkward_particles() {
  std::vector<ParticleConfig> out;
  const Real values[] = {1.0 / 3, -2.0 / 7, 0.1, 1e-300, 6.02214076e23, 4.9e-324, -0.0, 0.30000000000000004,
                         std::nextafter(1.0, 2.0)};
  const ParticleId ids[] = {0, 4, 5, 17, 4000000000u};
  for (std::size_t i = 0; i < 5; ++i) {
    ParticleConfig p;
    p.id = ids[i];
    const auto v = [&](std::size_t k) { return values[(i * 3 + k) % 9]; };
    p.position = Vec3(v(0), v(1), v(2));
    p.velocity = Vec3(v(3), v(4), v(5));
    p.angular_velocity = Vec3(v(6), v(7), v(8));
    p.radius = 0.001 * (1 + 1.0 / (i + 3));
    if (i % 3 == 0) p.mass = 7800 * 4.0 / 3.0 * pi / (i + 7);  // mass given
    if (i % 3 == 1) p.density = 7800.0 / 3;                    // density given
    p.material = i % 2 == 0 ? "steel" : "glass beads";           // neither given for i % 3 == 2
    out.push_back(p);
  }
  return out;
}

TEST_F(ParticleCsv, WhatIsWrittenReadsBackExactlyAndWritesTheSameBytes) {
  const std::vector<ParticleConfig> in = awkward_particles();
  const std::string first = (dir_ / "first.csv").string(), second = (dir_ / "second.csv").string();
  write_particle_csv(first, in);
  const std::vector<ParticleConfig> back = read_particle_csv(first, "unused");
  ASSERT_EQ(back.size(), in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    SCOPED_TRACE("particle " + std::to_string(i));
    EXPECT_EQ(back[i].id, in[i].id);
    for (int k = 0; k < 3; ++k) {  // bit for bit: -0.0 stays negative
      EXPECT_EQ(std::signbit(back[i].position[k]), std::signbit(in[i].position[k]));
      EXPECT_EQ(back[i].position[k], in[i].position[k]);
      EXPECT_EQ(back[i].velocity[k], in[i].velocity[k]);
      EXPECT_EQ(back[i].angular_velocity[k], in[i].angular_velocity[k]);
    }
    EXPECT_EQ(back[i].radius, in[i].radius);
    EXPECT_EQ(back[i].mass, in[i].mass);
    EXPECT_EQ(back[i].density, in[i].density);
    EXPECT_EQ(back[i].material, in[i].material);
  }
  write_particle_csv(second, back);
  EXPECT_EQ(read(second), read(first));
  EXPECT_EQ(read(first).substr(0, read(first).find('\n')), particle_csv_header);
}

TEST_F(ParticleCsv, ReadsIdMassDensityAndMaterialColumnsInAnyOrder) {
  // Row by row: a mass, a density, neither (the material's), blank lines and spaces around cells.
  const std::string path = write("in.csv",
                                 "material, radius,mass,density,z,y,x,id,wz\n"
                                 "glass,0.5,2.5,,3,2,1,12,-4\n"
                                 "\n"
                                 "steel ,0.25,,7800,0,0,0,3,0\r\n"
                                 "steel,0.125,,,1e-3,-0,7,8,0\n");
  ParticleCsvLayout layout;
  const std::vector<ParticleConfig> p = read_particle_csv(path, "default", &layout);
  ASSERT_EQ(p.size(), 3u);
  EXPECT_EQ(layout.lines, (std::vector<int>{2, 4, 5}));
  EXPECT_EQ(layout.id_column, 8);
  EXPECT_EQ(layout.material_column, 1);
  EXPECT_EQ(p[0].id, std::optional<ParticleId>(12));
  EXPECT_EQ(p[0].position, Vec3(1, 2, 3));
  EXPECT_EQ(p[0].angular_velocity, Vec3(0, 0, -4));
  EXPECT_EQ(p[0].radius, 0.5);
  EXPECT_EQ(p[0].mass, 2.5);
  EXPECT_EQ(p[0].density, 0.0);
  EXPECT_EQ(p[0].material, "glass");
  EXPECT_EQ(p[1].id, std::optional<ParticleId>(3));
  EXPECT_EQ(p[1].mass, 0.0);
  EXPECT_EQ(p[1].density, 7800.0);
  EXPECT_EQ(p[1].material, "steel");
  EXPECT_EQ(p[2].mass, 0.0);
  EXPECT_EQ(p[2].density, 0.0);
  EXPECT_EQ(p[2].position, Vec3(7, 0, 1e-3));
  // Without an id column rows have no id (the scene numbers them); the file's material is the default.
  const std::vector<ParticleConfig> plain = read_particle_csv(write("plain.csv", "x,y,z,radius\n0,0,0,1\n"), "glass");
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_FALSE(plain[0].id.has_value());
  EXPECT_EQ(plain[0].material, "glass");
}

TEST_F(ParticleCsv, BadIdsNameFileLineColumnAndTheValidRange) {
  const auto error = [&](const std::string& text) -> InputError {
    const std::string path = write("bad.csv", text);
    try {
      read_particle_csv(path);
    } catch (const InputError& e) {
      return e;
    }
    ADD_FAILURE() << "no error for: " << text;
    return InputError("", 0, 0, "", "");
  };
  const InputError repeated = error("x,y,z,radius,id\n0,0,0,1,5\n3,0,0,1,6\n6,0,0,1,5\n");
  EXPECT_EQ(repeated.file(), (dir_ / "bad.csv").string());
  EXPECT_EQ(repeated.line(), 4);
  EXPECT_EQ(repeated.column(), 5);
  EXPECT_EQ(repeated.field(), "id");
  EXPECT_NE(std::string(repeated.what()).find("also on line 2"), std::string::npos) << repeated.what();
  for (const std::string id : {"-1", "1.5", "4294967295", "x", ""}) {
    const InputError e = error("id,x,y,z,radius\n" + id + ",0,0,0,1\n");
    EXPECT_EQ(e.line(), 2) << id;
    EXPECT_EQ(e.column(), 1) << id;
    EXPECT_NE(std::string(e.what()).find("a whole number from 0 to 4294967294"), std::string::npos) << e.what();
  }
}

// A scene with particles from every source: ids from its files are kept, the others numbered after
// the largest in the order the scene lists them, and the World holds every particle in id order.
TEST_F(ParticleCsv, SceneKeepsFileIdsAndNumbersTheOthersAfterTheLargest) {
  write("a.csv", "id,x,y,z,radius,mass\n10,1,0,0,0.1,2.5\n3,2,0,0,0.1,\n");
  write("b.csv", "x,y,z,radius,id,material\n3,0,0,0.1,7,glass\n");
  const std::string scene_text = R"(
[[materials]]
name = "steel"
density = 7800
[[materials]]
name = "glass"
density = 2500
[[contacts]]
normal_stiffness = 1e5
[[particles]]
position = [4, 0, 0]
radius = 0.1
[[particle_files]]
file = "a.csv"
[[particle_files]]
file = "b.csv"
[[particles]]
position = [5, 0, 0]
radius = 0.1
density = 1000
[integrator]
dt = 1e-4
)";
  const Scene scene = load_scene_text(scene_text, "ids.toml", dir_.string());
  std::vector<ParticleId> ids;
  for (const ParticleConfig& p : scene.world.particles) ids.push_back(*p.id);
  EXPECT_EQ(ids, (std::vector<ParticleId>{3, 7, 10, 11, 12}));
  World world(scene.world);
  std::vector<ParticleId> held = world.state().id;  // in the slots' order, which is the world's own
  std::sort(held.begin(), held.end());
  EXPECT_EQ(held, ids);
  // Each id with the row or table that gave it (positions are unique, so they identify the input).
  EXPECT_EQ(world.position(3), Vec3(2, 0, 0));
  EXPECT_EQ(world.position(7), Vec3(3, 0, 0));
  EXPECT_EQ(world.position(10), Vec3(1, 0, 0));
  EXPECT_EQ(world.position(11), Vec3(4, 0, 0));
  EXPECT_EQ(world.position(12), Vec3(5, 0, 0));
  EXPECT_FALSE(world.index_of(0).has_value()) << "an id no row gave is no particle";
  // Masses as given: a mass, the material's density (steel, the first material), glass's, a density.
  const Real volume = 4.0 / 3.0 * pi * 0.1 * 0.1 * 0.1;
  const auto inv_mass = [&](ParticleId id) { return world.state().inv_mass[*world.index_of(id)]; };
  EXPECT_EQ(inv_mass(10), 1 / 2.5);
  EXPECT_EQ(inv_mass(3), 1 / (7800 * volume));
  EXPECT_EQ(inv_mass(7), 1 / (2500 * volume));
  EXPECT_EQ(inv_mass(12), 1 / (1000 * volume));
  EXPECT_EQ(world.materials().name(world.state().material[*world.index_of(7)]), "glass");
}

// The configs World::particles() gives build a world with the same ids, masses, inertias, radii,
// materials and state, bit for bit, and carry the mass or density each particle was given.
TEST_F(ParticleCsv, WorldParticlesRebuildTheSameWorld) {
  write("a.csv", "id,x,y,z,radius,mass,density,vx\n2,0,0,0.3,0.1,0.7,,1\n9,0.5,0,0.3,0.12,,3000,-1\n40,1,0,0.3,0.09,,,0\n");
  const std::string scene_text = R"(
[scene]
gravity = [0, 0, -9.81]
[[materials]]
name = "steel"
density = 7800
[[contacts]]
normal_stiffness = 1e5
normal_damping = { restitution = 0.5 }
sliding_friction = 0.3
[[walls]]
type = "plane"
[[particle_files]]
file = "a.csv"
[integrator]
dt = 1e-4
)";
  const Scene scene = load_scene_text(scene_text, "rebuild.toml", dir_.string());
  World first(scene.world);
  ASSERT_EQ(first.run_until(0.2), StepStatus::ok);
  const std::vector<ParticleConfig> configs = first.particles();
  ASSERT_EQ(configs.size(), 3u);
  EXPECT_EQ(configs[0].mass, 0.7);
  EXPECT_EQ(configs[1].density, 3000.0);
  EXPECT_EQ(configs[2].density, 7800.0) << "the material's density, so the file does not depend on the material table";
  WorldConfig again = scene.world;
  again.particles = configs;
  const World second(again);
  const State &a = first.state(), &b = second.state();
  EXPECT_EQ(b.id, a.id);
  EXPECT_EQ(b.inv_mass, a.inv_mass);
  EXPECT_EQ(b.inv_inertia, a.inv_inertia);
  EXPECT_EQ(b.radius, a.radius);
  EXPECT_EQ(b.material, a.material);
  EXPECT_EQ(b.position, a.position);
  EXPECT_EQ(b.velocity, a.velocity);
  EXPECT_EQ(b.angular_velocity, a.angular_velocity);
  EXPECT_NE(a.position[0], Vec3(0, 0, 0.3)) << "the first world moved";
}

// A fed particle may bring its id (from a file, say): it must be above every id given so far, since
// ids are never reused and slots follow them; without one it gets the next.
TEST_F(ParticleCsv, AddParticleTakesAGivenIdAboveTheOthers) {
  write("a.csv", "id,x,y,z,radius\n5,0,0,0,0.1\n9,1,0,0,0.1\n");
  const Scene scene = load_scene_text("[[contacts]]\nnormal_stiffness = 1e5\n[[particle_files]]\nfile = \"a.csv\"\n"
                                      "[integrator]\ndt = 1e-4\n",
                                      "feed.toml", dir_.string());
  World world(scene.world);
  ParticleConfig p;
  p.radius = 0.1;
  p.position = Vec3(2, 0, 0);
  p.id = 9;
  EXPECT_THROW(world.add_particle(p), std::invalid_argument) << "9 is taken";
  p.id = 7;
  EXPECT_THROW(world.add_particle(p), std::invalid_argument) << "7 is below a given id";
  EXPECT_EQ(world.particle_count(), 2u);
  p.id = 20;
  EXPECT_EQ(world.add_particle(p), 20u);
  p.id.reset();
  p.position = Vec3(3, 0, 0);
  EXPECT_EQ(world.add_particle(p), 21u);
  EXPECT_EQ(world.state().id, (std::vector<ParticleId>{5, 9, 20, 21}));
  const std::vector<ParticleConfig> now = world.particles();
  ASSERT_EQ(now.size(), 4u);
  EXPECT_EQ(now[3].position, Vec3(3, 0, 0));
  EXPECT_EQ(now[3].density, 2500.0) << "the default material's";
}

}  // namespace
}  // namespace dem
