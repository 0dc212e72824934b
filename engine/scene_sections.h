#pragma once
// The readers of a scene's sections, each filling its part of a Scene from the top-level table
// (scene_loader.cpp calls them in order). Loader side only.
#include <string>
#include <vector>

#include "engine/particle_generator.h"
#include "engine/scene.h"
#include "engine/toml_reader.h"

namespace dem::loader {

// engine/scene_materials.cpp
/// A `normal_damping` or `tangential_damping` table: exactly one way of giving the damping.
Damping read_damping(TableReader& r, const std::string& key, bool allow_restitution);
/// [[materials]]: without any, the built-in "default" material stays.
void read_materials(TableReader& top, Scene& scene);
bool known_material(const Scene& scene, const std::string& name);
/// The defined material names, "a, b, c" (for messages).
std::string material_names(const Scene& scene);
/// The material named at `key` (default: the first material); it must be defined.
std::string read_material_name(TableReader& r, const Scene& scene, const std::string& key);
/// [[contacts]]: at least one entry.
void read_contacts(TableReader& top, Scene& scene);

// engine/scene_walls.cpp
/// [[walls]]; a mesh wall's STL file (relative to `base_dir`) is read into its mesh here.
void read_walls(TableReader& top, Scene& scene, const std::string& base_dir);

// engine/scene_particles.cpp
/// The `size` table of a generator or a mill charge: the radius distribution.
void read_size(TableReader& r, GeneratorConfig& g);
/// Where a particle was given: the table `node` in `file`, under the name `field`.
ParticleSource source_of(const toml::node& node, const std::string& file, const std::string& field);
/// [[particles]], [[particle_files]] (relative to `base_dir`) and [[generators]]; `id_cells` gets,
/// per particle, where its id was given (a CSV cell; empty for a particle without one).
void read_particles(TableReader& top, Scene& scene, const std::string& base_dir,
                    std::vector<ParticleSource>& id_cells);

// engine/scene_mill.cpp
/// [mill]: the shell, lifters and end walls as prescribed-motion walls, and the charge (engine/mill.h).
void read_mill(TableReader& top, Scene& scene);

// engine/scene_settings.cpp
/// [scene], read by `r`: dimension, thickness, gravity, models, max_initial_overlap.
void read_model(TableReader& r, Scene& scene);
/// [integrator]; returns whether the scene sets level_max.
bool read_integrator(TableReader& top, Scene& scene);
/// [run], [output] and [broadphase].
void read_run_and_output(TableReader& top, Scene& scene);
/// [accuracy]: the metrics `dem trade` measures.
void read_accuracy(TableReader& top, Scene& scene);

}  // namespace dem::loader
