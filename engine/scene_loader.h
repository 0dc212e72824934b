#pragma once
// Scene files (TOML) to Scene structs: the driver of the loader side, the only files that use
// toml++ (scene_*.cpp, toml_reader.*). Strict: an unknown key (with a
// did-you-mean), a wrong type or a non-physical value throws InputError naming file, line, column,
// the field and what would be valid. Overrides `a.b[i].c=value` (the CLI's --set) are applied to
// the parsed document before it is read, so they pass the same checks.
#include <string>
#include <vector>

#include "engine/scene.h"
#include "engine/scene_schema.h"

namespace dem {

/// Reads, validates and resolves a scene file (relative particle files resolve against its folder).
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

/// The same from TOML text; `file` names it in errors and `base_dir` resolves relative paths.
Scene load_scene_text(const std::string& text, const std::string& file, const std::string& base_dir,
                      const std::vector<std::string>& overrides = {});

/// Physical checks that need the whole particle set: initial overlaps beyond max_initial_overlap and
/// particles outside the walls. Called by the loaders; throws InputError.
void check_initial_state(const Scene& scene);

}  // namespace dem
