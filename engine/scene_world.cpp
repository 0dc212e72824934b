// World::load, the embedding's start from a scene file: declared with the World (world.h), defined
// here on the loader side so that the core never calls the loader, and in a file of its own so that
// the loader alone (the fuzz target) builds without the World.
#include <memory>

#include "engine/scene_loader.h"
#include "engine/world.h"

namespace dem {

std::unique_ptr<World> World::load(const std::string& scene_path, const std::vector<std::string>& overrides,
                                   Scene* scene) {
  Scene loaded = load_scene(scene_path, overrides);
  auto world = std::make_unique<World>(loaded.world);
  if (scene != nullptr) *scene = std::move(loaded);
  return world;
}

}  // namespace dem
