#pragma once
// The keys a scene file may hold, each with its unit: the loader's schema. The table readers
// (toml_reader.h) ask only for these keys; scenes/README.md documents each with the same unit.
#include <set>
#include <string>
#include <vector>

namespace dem {

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

/// The key of scene_keys() with this path, or null.
const SceneKey* find_scene_key(const std::string& path);

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

/// Tells this thread's SceneKeyRecorder, if any, that the loader asked for the key at `path`.
void record_scene_key(const std::string& path);

}  // namespace dem
