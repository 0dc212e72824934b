#pragma once
// A scene: the world to build plus how to run it and what to write. Filled by scene_loader from a
// TOML file (scenes/README.md documents every key) or in code by an embedding program.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/checkpoint.h"
#include "engine/config.h"
#include "engine/mill.h"

namespace dem {

struct RunSettings {
  Real until = 1;                    // simulated end time [s]
  Real stop_kinetic_energy = -1;     // stop once the translational kinetic energy falls below this [J]; negative: off
  Real stop_check_after = 0;         // earliest time the kinetic-energy stop applies [s]
};

struct OutputSettings {
  Real interval = 0.01;              // series rows at the first sync time at or after each multiple [s]
  Real snapshot_interval = -1;       // VTK snapshots [s]; negative: equal to interval; 0: none
  std::string settled_file;          // when set, particles are written here (CSV) at the end
  bool trajectories = false;         // trajectories.csv: every particle's state at every row (few-body scenes)
  bool contacts = false;             // the contact network (contacts_<n>.vtp, contacts.pvd) with each snapshot
  bool vtk_ascii = false;            // VTK files as text instead of appended raw binary
};

/// Metric names an `[accuracy]` section may list (scenes/README.md): `dem trade` measures these.
inline constexpr std::array<const char*, 8> accuracy_metric_names = {"trajectory",     "dissipated_energy",
                                                                     "bed_height",     "kinetic_energy",
                                                                     "wall_force",     "power_draw",
                                                                     "collision_spectrum", "fines_dissipation_share"};

/// What `dem trade` compares against its reference run; not physics (not in the physics hash).
struct AccuracySettings {
  std::vector<std::string> metrics;  // names from accuracy_metric_names, each once; empty: chosen from the scene
};

/// Where a particle came from, for error messages that point into the input.
struct ParticleSource {
  std::string file;
  int line = 0;
  int column = 0;
  std::string field;  // e.g. "particles[3]" or "generators[0]"
};

struct Scene {
  std::string name;                  // default: the file's stem
  std::string file;                  // the scene file's path
  WorldConfig world;
  RunSettings run;
  OutputSettings output;
  AccuracySettings accuracy;
  std::optional<MillConfig> mill;    // a [mill] section: its walls are in world.walls from mill->first_wall
  Real max_initial_overlap = 0.01;   // relative to the smaller radius of a pair [-]
  std::vector<ParticleSource> sources;  // one per particle of world.particles
  std::vector<std::uint64_t> seeds;     // generator seeds, for provenance
  std::uint64_t physics_hash = 0;       // hash of the resolved scene without [run], [output] and [accuracy]
  std::uint64_t body_hash = 0;          // the same without [integrator] and [broadphase] too
  /// What a checkpoint of this scene records of it (World::save_checkpoint).
  SceneHashes hashes() const { return {physics_hash, body_hash}; }
};

}  // namespace dem
