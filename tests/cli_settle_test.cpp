// The settle workflow through the program: a run stops once the kinetic energy is below
// run.stop_kinetic_energy and writes the settled particles as CSV, which loads back as a valid bed;
// a run restarted from a settled file has the ids, masses, inertias, radii, materials and state of
// the run that wrote it (checked against a World built in this process from the first scene), its
// ids are those of the snapshots, and a mass given in a particle file survives the round trip.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <unistd.h>

#include "engine/materials.h"
#include "engine/particle_csv.h"
#include "engine/world.h"
#include "tests/cli_support.h"

namespace {

namespace fs = std::filesystem;

using dem::test::cli::read_text;
using dem::test::cli::TempDir;
using dem::test::cli::write_text;

int run_dem(const std::string& arguments) { return dem::test::cli::run_dem_status(arguments + " --quiet > /dev/null"); }

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

/// The ids of the last particle snapshot of a run (particles_<n>.vtp with the largest n).
/// A copy of `s` with its slots in id order (a fixed-step run may re-sort them in space).
dem::State in_id_order(const dem::State& s) {
  std::vector<std::uint32_t> order;
  for (const dem::ParticleIndex p : s.index_of_id)
    if (p != dem::removed_slot) order.push_back(p);
  dem::State ordered = s;
  ordered.permute(order);
  return ordered;
}

std::vector<dem::ParticleId> last_snapshot_ids(const fs::path& out) {
  int last = -1;
  for (const auto& entry : fs::directory_iterator(out)) {
    std::smatch m;
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, m, std::regex(R"(particles_(\d+)\.vtp)"))) last = std::max(last, std::stoi(m[1]));
  }
  std::vector<dem::ParticleId> ids;
  if (last < 0) return ids;
  const std::string xml = read_text(out / ("particles_" + std::to_string(last) + ".vtp"));
  std::smatch m;
  if (!std::regex_search(xml, m, std::regex(R"(Name="id"[^>]*>([^<]*)<)"))) return ids;
  std::istringstream values(m[1].str());
  for (unsigned long id = 0; values >> id;) ids.push_back(static_cast<dem::ParticleId>(id));
  return ids;
}

// Particles from every source: a mass, a density and neither given, two materials, file ids out of
// order, and particles without ids ([[particles]], a generator) numbered after them.
const char* mixed_scene_head = R"(
[scene]
gravity = [0, 0, -9.81]
[[materials]]
name = "steel"
density = 7800
[[materials]]
name = "glass"
density = 2500
[[contacts]]
normal_stiffness = 1e4
normal_damping = { restitution = 0.5 }
sliding_friction = 0.3
rolling_friction = 0.01
[[walls]]
type = "plane"
material = "steel"
[integrator]
dt = 1e-4
[run]
until = 0.06
[output]
interval = 0.02
snapshot_interval = 0.03
settled_file = "settled.csv"
vtk_format = "ascii"   # last_snapshot_ids reads the ids as text
)";

const char* mixed_scene_particles = R"(
[[particles]]
position = [0.3, 0.3, 0.05]
velocity = [0.1, 0, 0]
radius = 0.011
mass = 0.0123
material = "glass"
[[particle_files]]
file = "in.csv"
material = "steel"
[[particles]]
position = [0.3, 0, 0.05]
radius = 0.012
density = 5000
[[generators]]
count = 6
seed = 4
material = "glass"
region = { type = "box", min = [-0.1, -0.1, 0.1], max = [0.1, 0.1, 0.2] }
size = { distribution = "uniform", min = 0.008, max = 0.012 }
)";

// id, x, y, z, radius, mass, density, material: a mass, a density, neither (steel's), glass by column.
const char* mixed_csv =
    "id,x,y,z,radius,mass,density,material,vz\n"
    "30,0,0.3,0.02,0.01,0.05,,steel,-0.5\n"
    "4,0.2,0.2,0.03,0.015,,1234.5,glass,0\n"
    "12,-0.2,0,0.04,0.0125,,,steel,0.25\n";

TEST(CliSettle, RestartFromASettledFileHasTheIdsMassesAndStateOfTheRunThatWroteIt) {
  const TempDir tmp("restart");
  const fs::path scene = tmp.path() / "mixed.toml", out = tmp.path() / "first";
  write_text(tmp.path() / "in.csv", mixed_csv);
  write_text(scene, std::string(mixed_scene_head) + mixed_scene_particles);
  ASSERT_EQ(run_dem("run " + scene.string() + " --threads 2 --out " + out.string()), 0);

  // What the first run held: the same scene built here and run as far on one thread.
  const std::unique_ptr<dem::World> first = dem::World::load(scene.string(), {"run.threads=1"});
  const dem::State before = in_id_order(first->state());  // ids, masses, inertias, radii, materials stay
  ASSERT_EQ(first->run_until(0.06), dem::StepStatus::ok);
  const dem::State held = in_id_order(first->state());
  EXPECT_EQ(held.id, (std::vector<dem::ParticleId>{4, 12, 30, 31, 32, 33, 34, 35, 36, 37, 38}))
      << "the file's ids, then the others in scene order after the largest";

  // The settled file: the snapshot's ids, and each row's mass or density as the input gave it.
  const fs::path settled = out / "settled.csv";
  const std::vector<dem::ParticleConfig> rows = dem::read_particle_csv(settled.string());
  ASSERT_EQ(rows.size(), held.size());
  std::vector<dem::ParticleId> ids;
  for (const auto& r : rows) ids.push_back(*r.id);
  EXPECT_EQ(ids, held.id);
  EXPECT_EQ(last_snapshot_ids(out), held.id) << "one numbering for snapshots and settled files";
  EXPECT_EQ(rows[2].mass, 0.05);  // id 30
  EXPECT_EQ(rows[2].density, 0.0);
  EXPECT_EQ(rows[0].density, 1234.5);  // id 4
  EXPECT_EQ(rows[0].material, "glass");
  EXPECT_EQ(rows[1].density, 7800.0);  // id 12: steel's density
  EXPECT_EQ(rows[3].mass, 0.0123);     // id 31, the first [[particles]] table
  EXPECT_EQ(rows[4].density, 5000.0);  // id 32

  // A scene that starts from the settled file builds the particles the first run ended with.
  const fs::path restart_scene = tmp.path() / "restart.toml";
  write_text(restart_scene, std::string(mixed_scene_head) + "[[particle_files]]\nfile = \"first/settled.csv\"\n");
  const std::unique_ptr<dem::World> restarted = dem::World::load(restart_scene.string(), {"run.threads=1"});
  const dem::State again = in_id_order(restarted->state());
  EXPECT_EQ(again.id, before.id);
  EXPECT_EQ(again.inv_mass, before.inv_mass);
  EXPECT_EQ(again.inv_inertia, before.inv_inertia);
  EXPECT_EQ(again.radius, before.radius);
  EXPECT_EQ(again.material, before.material);
  EXPECT_EQ(again.position, held.position);
  EXPECT_EQ(again.velocity, held.velocity);
  EXPECT_EQ(again.angular_velocity, held.angular_velocity);
  // ... and writing them again gives the file's bytes.
  dem::write_particle_csv((tmp.path() / "again.csv").string(), restarted->particles());
  EXPECT_EQ(read_text(tmp.path() / "again.csv"), read_text(settled));

  // The program restarted from it keeps ids, radii, masses, densities and materials once more.
  ASSERT_EQ(run_dem("run " + restart_scene.string() + " --out " + (tmp.path() / "second").string()), 0);
  const std::vector<dem::ParticleConfig> later =
      dem::read_particle_csv((tmp.path() / "second" / "settled.csv").string());
  ASSERT_EQ(later.size(), rows.size());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(later[k].id, rows[k].id);
    EXPECT_EQ(later[k].radius, rows[k].radius);
    EXPECT_EQ(later[k].mass, rows[k].mass);
    EXPECT_EQ(later[k].density, rows[k].density);
    EXPECT_EQ(later[k].material, rows[k].material);
  }
  EXPECT_EQ(last_snapshot_ids(tmp.path() / "second"), held.id);
}

// Steel spheres given by their mass in a scene whose material is the default 2500 kg/m³: the
// settled file keeps the mass, and a world built from it has it.
TEST(CliSettle, AMassColumnSurvivesTheSettledFile) {
  const TempDir tmp("mass");
  const double radius = 0.005, mass = 7800 * 4.0 / 3.0 * dem::pi * radius * radius * radius;
  std::string csv = "x,y,z,radius,mass\n";
  for (int i = 0; i < 3; ++i) csv += std::to_string(0.02 * i) + ",0,0," + number(radius) + "," + number(mass) + "\n";
  write_text(tmp.path() / "steel.csv", csv);
  const std::string head = R"(
[[contacts]]
normal_stiffness = 1e4
[integrator]
dt = 1e-4
[run]
until = 0.01
[output]
settled_file = "settled.csv"
)";
  write_text(tmp.path() / "steel.toml", head + "[[particle_files]]\nfile = \"steel.csv\"\n");
  ASSERT_EQ(run_dem("run " + (tmp.path() / "steel.toml").string() + " --out " + (tmp.path() / "out").string()), 0);
  const std::vector<dem::ParticleConfig> rows = dem::read_particle_csv((tmp.path() / "out" / "settled.csv").string());
  ASSERT_EQ(rows.size(), 3u);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    EXPECT_EQ(rows[k].id, std::optional<dem::ParticleId>(k)) << "ids from 0, as in snapshots";
    EXPECT_EQ(rows[k].mass, mass);
    EXPECT_EQ(rows[k].density, 0.0);
  }
  write_text(tmp.path() / "restart.toml", head + "[[particle_files]]\nfile = \"out/settled.csv\"\n");
  const std::unique_ptr<dem::World> world = dem::World::load((tmp.path() / "restart.toml").string());
  ASSERT_EQ(world->particle_count(), 3u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(world->state().inv_mass[k], 1 / mass);
}

TEST(CliSettle, StopsWhenSettledAndWritesALoadableBed) {
  const auto out = std::filesystem::temp_directory_path() / ("dem_settle_" + std::to_string(::getpid()));
  std::filesystem::remove_all(out);
  const std::string command = std::string(DEM_PROGRAM) + " run " + DEM_SOURCE_DIR +
                              "/tests/scenes/settle_small.toml --quiet --out " + out.string();
  ASSERT_EQ(std::system(command.c_str()), 0) << command;

  std::ifstream summary(out / "summary.json");
  const std::string text((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"stop_reason\": \"kinetic energy below run.stop_kinetic_energy\""), std::string::npos)
      << "the run must stop by the kinetic-energy criterion, not at run.until";

  const auto bed = dem::read_particle_csv((out / "settled.csv").string());
  ASSERT_EQ(bed.size(), 200u);
  double max_overlap_ratio = 0;
  for (std::size_t a = 0; a < bed.size(); ++a) {
    const auto& p = bed[a];
    EXPECT_LT(p.velocity.norm(), 1e-3) << "particle " << a << " is not at rest";
    // Inside the box [0, 0.06]^2 x [0, 0.1] up to the contact overlap, and resting in its lower half.
    EXPECT_GE(p.position.minCoeff(), p.radius * 0.99);
    EXPECT_LE(p.position.x(), 0.06 - p.radius * 0.99);
    EXPECT_LE(p.position.y(), 0.06 - p.radius * 0.99);
    EXPECT_LE(p.position.z(), 0.05);
    for (std::size_t b = a + 1; b < bed.size(); ++b) {
      const double overlap = p.radius + bed[b].radius - (p.position - bed[b].position).norm();
      max_overlap_ratio = std::max(max_overlap_ratio, overlap / std::min(p.radius, bed[b].radius));
    }
  }
  // A bed that loads under the default max_initial_overlap of 1% of the smaller radius.
  EXPECT_LT(max_overlap_ratio, 0.01);
  EXPECT_GT(max_overlap_ratio, 0.0) << "a settled bed has contacts";
  std::filesystem::remove_all(out);
}

}  // namespace
