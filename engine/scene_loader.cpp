// Reads a TOML scene into a Scene: parses the text, applies the `--set` overrides
// (scene_overrides.h), reads each section (scene_sections.h) through strict table readers
// (toml_reader.h) that record the keys they consumed, so whatever is left over is an unknown key,
// checks what spans sections (scene_validation.h) and derives the physics hash.
#include "engine/scene_loader.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <toml++/toml.h>

#include "engine/input_error.h"
#include "engine/scene_overrides.h"
#include "engine/scene_sections.h"
#include "engine/scene_validation.h"
#include "engine/toml_reader.h"
#include "engine/triangle_mesh.h"

namespace dem {
namespace {

std::uint64_t fnv1a(const std::string& text) {
  std::uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) h = (h ^ c) * 1099511628211ull;
  return h;
}

/// FNV-1a of a mesh's vertex coordinates and corner indices.
std::uint64_t mesh_fingerprint(const TriangleMesh& mesh) {
  std::string bytes;
  bytes.append(reinterpret_cast<const char*>(mesh.vertices().data()), mesh.vertices().size() * sizeof(Vec3));
  bytes.append(reinterpret_cast<const char*>(mesh.triangles().data()),
               mesh.triangles().size() * sizeof(std::array<std::uint32_t, 3>));
  return fnv1a(bytes);
}

}  // namespace

Scene load_scene_text(const std::string& text, const std::string& file, const std::string& base_dir,
                      const std::vector<std::string>& overrides) {
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    throw InputError(file, static_cast<int>(e.source().begin.line), static_cast<int>(e.source().begin.column), "",
                     "TOML syntax error: " + std::string(e.description()));
  }
  for (const std::string& o : overrides) loader::apply_override(root, o);

  Scene scene;
  scene.file = file;
  scene.name = std::filesystem::path(file).stem().string();
  loader::TableReader top(root, "", file);
  if (const toml::table* t = top.table("scene")) {
    loader::TableReader r(*t, "scene", file);
    loader::read_model(r, scene);
    r.finish();
  }
  loader::read_materials(top, scene);
  loader::read_contacts(top, scene);
  loader::read_walls(top, scene, base_dir);
  std::vector<ParticleSource> id_cells;
  loader::read_particles(top, scene, base_dir, id_cells);
  loader::read_mill(top, scene);
  loader::check_contact_pairs(top, scene);
  const bool level_max_given = loader::read_integrator(top, scene);
  loader::read_run_and_output(top, scene);
  loader::read_accuracy(top, scene);
  top.finish();
  // Outputs happen at sync times, so by default a doubling run's longest step (the sync interval)
  // is at most the output interval: `--set integrator.control=doubling` keeps a scene's rows.
  IntegratorConfig& integrator = scene.world.integrator;
  std::string derived;
  if (integrator.control == Control::doubling && !level_max_given) {
    const Real dt_base = integrator.dt_base > 0 ? integrator.dt_base : integrator.dt;
    const Real steps = std::floor(std::log2(scene.output.interval / dt_base) + 1e-9);
    integrator.level_max = static_cast<int>(std::clamp(steps, Real(integrator.level_min), Real(10)));
    derived = "\nderived level_max = " + std::to_string(integrator.level_max);
  }
  if (scene.world.particles.empty())
    top.fail("particles", "the scene has no particles: add [[particles]], [[particle_files]] or [[generators]]");
  loader::assign_particle_ids(scene, std::move(id_cells));
  // The physics hash ignores how long the run lasts and what it writes, so a run can be resumed
  // with another end time or output interval, but never with other physics. The body hash ignores
  // the integrator's and broadphase's settings too: a run may start from a checkpoint of the same
  // particles, materials, walls and model under another control, step or tolerance.
  toml::table physics = root;
  physics.erase("run");
  physics.erase("output");
  physics.erase("accuracy");
  // A mesh wall's triangles are physics too, whatever file they came from.
  std::string meshes;
  for (const WallConfig& w : scene.world.walls)
    if (w.mesh) meshes += "\nmesh " + w.name + " " + std::to_string(mesh_fingerprint(*w.mesh));
  std::ostringstream resolved;
  resolved << physics << derived << meshes;  // a level_max derived from the output interval is physics too
  scene.physics_hash = fnv1a(resolved.str());
  toml::table body = std::move(physics);
  body.erase("integrator");
  body.erase("broadphase");
  std::ostringstream resolved_body;
  resolved_body << body << meshes;
  scene.body_hash = fnv1a(resolved_body.str());
  check_initial_state(scene);
  return scene;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the scene file");
  std::stringstream text;
  text << in.rdbuf();
  return load_scene_text(text.str(), path, std::filesystem::path(path).parent_path().string(), overrides);
}

}  // namespace dem
