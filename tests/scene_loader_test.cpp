// The scene loader (engine/scene_loader.h) as a whole.
// Contact parameters are needed for the material pairs that can meet, and only for them:
//  - walls against walls need no [[contacts]] entry, a particle material against a wall material
//    does (the message names both materials, the file and the entry to add);
//  - leaving out an entry for walls against walls changes no result (a mill's state hash).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "engine/input_error.h"
#include "engine/scene_loader.h"
#include "engine/world.h"

namespace dem {
namespace {

namespace fs = std::filesystem;

const fs::path source_dir{DEM_SOURCE_DIR};

// Particles of steel and glass; walls of liner and rubber; a material nothing uses.
const std::string pair_scene_head = R"(
[[materials]]
name = "steel"
density = 7800
[[materials]]
name = "liner"
density = 7800
[[materials]]
name = "glass"
density = 2500
[[materials]]
name = "rubber"
density = 1100
[[materials]]
name = "spare"
density = 1000
[[walls]]
type = "plane"
material = "liner"
[[walls]]
type = "plane"
point = [0, 0, 3]
normal = [0, 0, -1]
material = "rubber"
[[particles]]
position = [0, 0, 1]
radius = 0.1
material = "steel"
[[particles]]
position = [0, 0, 2]
radius = 0.1
material = "glass"
[integrator]
dt = 1e-4
)";

std::string contact(const std::string& a, const std::string& b) {
  return "[[contacts]]\nmaterials = [\"" + a + "\", \"" + b + "\"]\nnormal_stiffness = 1e5\n";
}

TEST(ContactPairs, OnlyPairsThatCanMeetNeedAnEntry) {
  // Particles against particles and against each wall material: six pairs. Liner-rubber,
  // liner-liner, rubber-rubber and every pair with "spare" can never meet.
  const std::vector<std::pair<std::string, std::string>> meeting = {
      {"steel", "steel"}, {"steel", "glass"}, {"glass", "glass"}, {"steel", "liner"},
      {"glass", "liner"}, {"rubber", "steel"}, {"glass", "rubber"}};
  std::string all;
  for (const auto& [a, b] : meeting) all += contact(a, b);
  EXPECT_NO_THROW(load_scene_text(pair_scene_head + all, "pairs.toml", "."));
  // Leaving out any one of them is an error naming both materials, the file and the entry to add.
  for (std::size_t k = 0; k < meeting.size(); ++k) {
    std::string some;
    for (std::size_t i = 0; i < meeting.size(); ++i)
      if (i != k) some += contact(meeting[i].first, meeting[i].second);
    const auto& [a, b] = meeting[k];
    try {
      load_scene_text(pair_scene_head + some, "pairs.toml", ".");
      ADD_FAILURE() << a << "-" << b << " left out, and the scene loads";
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(e.file(), "pairs.toml");
      EXPECT_GT(e.line(), 0);
      EXPECT_EQ(e.field(), "contacts");
      EXPECT_NE(message.find("no contact parameters for materials"), std::string::npos) << message;
      EXPECT_NE(message.find("'" + a + "'"), std::string::npos) << message;
      EXPECT_NE(message.find("'" + b + "'"), std::string::npos) << message;
      EXPECT_TRUE(message.find("materials = [\"" + a + "\", \"" + b + "\"]") != std::string::npos ||
                  message.find("materials = [\"" + b + "\", \"" + a + "\"]") != std::string::npos)
          << message;
    }
  }
  // A default entry covers every pair.
  EXPECT_NO_THROW(load_scene_text(pair_scene_head + "[[contacts]]\nnormal_stiffness = 1e5\n", "pairs.toml", "."));
}

// The 2D mill with and without the liner-liner entry it used to carry: the same state, bit for bit.
TEST(ContactPairs, AnEntryForWallsAgainstWallsChangesNothing) {
  const fs::path path = source_dir / "scenes" / "mill_2d.toml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string with = text.str() + contact("liner", "liner");
  const std::vector<std::string> overrides = {"run.threads=2"};
  World without_entry(load_scene_text(text.str(), path.string(), path.parent_path().string(), overrides).world);
  World with_entry(load_scene_text(with, path.string(), path.parent_path().string(), overrides).world);
  ASSERT_EQ(without_entry.run_until(0.1), StepStatus::ok);
  ASSERT_EQ(with_entry.run_until(0.1), StepStatus::ok);
  EXPECT_EQ(without_entry.state_hash(), with_entry.state_hash());
  EXPECT_GT(without_entry.wall_contacts().size(), 0u) << "the charge touches the liner";
}

}  // namespace
}  // namespace dem
