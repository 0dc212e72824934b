#pragma once
// Scene files (TOML) to Scene structs: the one place that uses toml++. Strict: an unknown key (with a
// did-you-mean), a wrong type or a non-physical value throws InputError naming file, line, column,
// the field and what would be valid. Overrides `a.b[i].c=value` (the CLI's --set) are applied to
// the parsed document before it is read, so they pass the same checks.
#include <set>
#include <string>
#include <vector>

#include "engine/scene.h"

namespace dem {

/// Reads, validates and resolves a scene file (relative particle files resolve against its folder).
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

/// The same from TOML text; `file` names it in errors and `base_dir` resolves relative paths.
Scene load_scene_text(const std::string& text, const std::string& file, const std::string& base_dir,
                      const std::vector<std::string>& overrides = {});

/// A key a scene may hold: its dotted path without array indices ("walls.radius",
/// "contacts.normal_damping.gamma"; tables too, "mill.charge"), and its unit as scenes/README.md
/// writes it ("m/s", "kg/m³"; "–" for a dimensionless number, empty for none).
struct SceneKey {
  std::string path;
  std::string unit;
};

/// Every key a scene may hold. The loader asks for no other (it would throw std::logic_error) and
/// finds any other unknown; scenes/README.md documents each with its unit.
const std::vector<SceneKey>& scene_keys();

/// While alive, collects on this thread the scene_keys() the loader asks for (whether or not a scene
/// holds them): what a set of loads accepts, for tests.
class SceneKeyRecorder {
 public:
  SceneKeyRecorder();
  ~SceneKeyRecorder();
  SceneKeyRecorder(const SceneKeyRecorder&) = delete;
  SceneKeyRecorder& operator=(const SceneKeyRecorder&) = delete;
  const std::set<std::string>& keys() const { return keys_; }

 private:
  std::set<std::string> keys_;
  std::set<std::string>* previous_;
};

/// Physical checks that need the whole particle set: initial overlaps beyond max_initial_overlap and
/// particles outside the walls. Called by the loaders; throws InputError.
void check_initial_state(const Scene& scene);

}  // namespace dem
