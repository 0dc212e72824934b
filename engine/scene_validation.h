#pragma once
// Checks of a scene that span its sections: contact parameters for every pair of materials that can
// meet, particle ids (unique, and their order), and the initial state (overlaps, particles outside
// walls). Each throws InputError at the place in the scene or its files that is wrong.
#include <vector>

#include "engine/scene.h"

namespace dem {

// check_initial_state (scene_loader.h) is defined in scene_validation.cpp too.

namespace loader {

class TableReader;  // engine/toml_reader.h

/// Every pair of materials that can meet has contact parameters (`top`: the scene's top table).
void check_contact_pairs(TableReader& top, const Scene& scene);

/// Gives every particle an id and orders particles by id when a particle file gives ids
/// (`id_cells`: where each id was given); rejects an id given twice.
void assign_particle_ids(Scene& scene, std::vector<ParticleSource> id_cells);

}  // namespace loader
}  // namespace dem
