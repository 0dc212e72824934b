// The scene loader (engine/scene_loader.h) as a whole.
// The scene key reference (scenes/README.md) and the loader stay in step:
//  - every key of the loader's schema (scene_keys()) has a row in a key table of scenes/README.md,
//    and every key a table documents is in the schema, with the same unit;
//  - the loader asks for every key of its schema (it asks for none outside it: it would throw), so
//    a documented key is one a scene may hold.
// Contact parameters are needed for the material pairs that can meet, and only for them:
//  - walls against walls need no [[contacts]] entry, a particle material against a wall material
//    does (the message names both materials, the file and the entry to add);
//  - leaving out an entry for walls against walls changes no result (a mill's state hash).
// The reference's layout, which the parser below relies on: a heading (## or ###) that names a
// section in backticks (`[scene]`, `[[walls]]`, `[mill]`) starts that section; a heading naming none
// ends it. In a section, the first cell of each row of a table after its header row holds the keys
// the row documents, each in backticks, relative to the section; keys of a table inside a table are
// dotted (`region.type` in [[generators]], `charge.size.radius` in [mill]). The column headed
// "unit" holds one unit for all the row's keys or one per key, comma-separated ("–": a
// dimensionless number; empty: none).
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
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

std::vector<std::string> backticked(const std::string& text) {
  std::vector<std::string> out;
  const std::regex code("`([^`]*)`");
  for (auto it = std::sregex_iterator(text.begin(), text.end(), code); it != std::sregex_iterator(); ++it)
    out.push_back((*it)[1]);
  return out;
}

std::vector<std::string> cells(const std::string& row) {
  std::vector<std::string> out;
  std::string cell;
  for (std::size_t i = 1; i < row.size(); ++i) {
    if (row[i] == '|' && row[i - 1] != '\\') {
      const auto b = cell.find_first_not_of(' '), e = cell.find_last_not_of(' ');
      out.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
      cell.clear();
    } else {
      cell += row[i];
    }
  }
  return out;
}

struct Reference {
  std::map<std::string, std::string> keys;  // path as scene_keys() spells it -> unit
  std::vector<std::string> complaints;       // rows the parser could not read
};

Reference parse_reference(const fs::path& path) {
  Reference ref;
  std::ifstream in(path);
  std::string line, section;  // section: "" outside any
  bool header_row = false;    // the next table row is a header
  int unit_column = -1;       // of the current table
  int number = 0;
  const std::regex section_name(R"(^\[\[?([a-z_]+)\]\]?$)");
  const std::regex key_name(R"(^[a-z_]+(\.[a-z_]+)*$)");
  while (std::getline(in, line)) {
    ++number;
    if (line.rfind("#", 0) == 0) {
      section.clear();
      std::vector<std::string> named;
      for (const std::string& code : backticked(line)) {
        std::smatch m;
        if (std::regex_match(code, m, section_name)) named.push_back(m[1]);
      }
      if (named.size() > 1) ref.complaints.push_back("line " + std::to_string(number) + ": a heading names one section");
      if (named.size() == 1) {
        section = named[0];
        ref.keys[section] = "";
      }
      header_row = true;
      continue;
    }
    if (line.rfind("|", 0) != 0) {
      header_row = true;  // a table starts after any other line
      continue;
    }
    const std::vector<std::string> row = cells(line);
    if (header_row) {  // the header row; the separator row follows
      header_row = false;
      const auto unit = std::find(row.begin(), row.end(), "unit");
      unit_column = unit == row.end() ? -1 : static_cast<int>(unit - row.begin());
      if (!section.empty() && unit_column < 0)
        ref.complaints.push_back("line " + std::to_string(number) + ": a key table without a unit column");
      continue;
    }
    if (line.rfind("|---", 0) == 0 || line.rfind("|:--", 0) == 0 || section.empty()) continue;
    const std::vector<std::string> keys = backticked(row.at(0));
    const auto where = "line " + std::to_string(number) + ": ";
    if (keys.empty()) ref.complaints.push_back(where + "a row of [" + section + "] without a key");
    std::vector<std::string> units;
    if (unit_column >= 0 && unit_column < static_cast<int>(row.size())) {
      std::istringstream list(row[unit_column]);
      for (std::string u; std::getline(list, u, ',');) units.push_back(u.erase(0, std::min(u.size(), u.find_first_not_of(' '))));
    }
    if (units.empty()) units.push_back("");
    if (units.size() != 1 && units.size() != keys.size())
      ref.complaints.push_back(where + "give one unit for the row or one per key");
    for (std::size_t k = 0; k < keys.size(); ++k) {
      if (!std::regex_match(keys[k], key_name)) {
        ref.complaints.push_back(where + "'" + keys[k] + "' is not a key");
        continue;
      }
      const std::string unit = units.size() == keys.size() ? units[k] : units[0];
      const auto [it, fresh] = ref.keys.emplace(section + "." + keys[k], unit);
      if (!fresh && it->second != unit)
        ref.complaints.push_back(where + "'" + keys[k] + "' documented again with another unit (" + unit + ", " + it->second + ")");
    }
  }
  return ref;
}

std::string listed(const std::vector<std::string>& items) {
  std::string s;
  for (const std::string& item : items) s += "\n  " + item;
  return s;
}

TEST(SceneKeys, TheReferenceDocumentsExactlyTheKeysTheLoaderAccepts) {
  const Reference ref = parse_reference(source_dir / "scenes" / "README.md");
  EXPECT_TRUE(ref.complaints.empty()) << "scenes/README.md:" << listed(ref.complaints);
  std::map<std::string, std::string> schema;
  for (const SceneKey& k : scene_keys()) EXPECT_TRUE(schema.emplace(k.path, k.unit).second) << k.path << " twice in the schema";
  std::vector<std::string> undocumented, unknown, units;
  for (const auto& [path, unit] : schema) {
    const auto doc = ref.keys.find(path);
    if (doc == ref.keys.end())
      undocumented.push_back(path);
    else if (doc->second != unit)
      units.push_back(path + ": '" + doc->second + "' in scenes/README.md, '" + unit + "' in the loader");
  }
  for (const auto& [path, unit] : ref.keys)
    if (!schema.count(path)) unknown.push_back(path);
  EXPECT_TRUE(undocumented.empty()) << "keys the loader accepts that scenes/README.md does not document:" << listed(undocumented);
  EXPECT_TRUE(unknown.empty()) << "keys scenes/README.md documents that the loader does not accept:" << listed(unknown);
  EXPECT_TRUE(units.empty()) << "units that differ:" << listed(units);
}

// Scenes that between them take every branch of the loader: each wall type, both generator regions,
// every size distribution, both kinds of mill charge, both damping tables, [accuracy].
const char* branch_scenes[] = {
    R"(
[[contacts]]
normal_stiffness = 1e5
normal_damping = { gamma = 10 }
tangential_damping = { gamma = 5 }
[[walls]]
type = "cylinder"
radius = 2
[[walls]]
type = "prism"
point = [0, 0, -1.5]
length = 0.2
profile = [[-0.1, -0.1, -1.5], [0.1, -0.1, -1.5], [0, 0.1, -1.5]]
[[particles]]
radius = 0.1
[[generators]]
count = 2
region = { type = "cylinder", radius = 0.5, length = 0.5, center = [0, 0, 1] }
size = { distribution = "normal", mean = 0.05, std = 0.01, min = 0.04, max = 0.06 }
[[generators]]
count = 2
region = { type = "box", min = [0.5, 0.5, 0.5], max = [1, 1, 1] }
size = { distribution = "lognormal", median = 0.05, sigma = 0.1, min = 0.04, max = 0.06 }
[[generators]]
count = 2
region = { type = "box", min = [-1, -1, -1], max = [-0.5, -0.5, -0.5] }
size = { distribution = "uniform", min = 0.04, max = 0.06 }
[integrator]
dt = 1e-4
[accuracy]
metrics = ["trajectory"]
)",
    R"(
[scene]
gravity = [0, -9.81, 0]
[[contacts]]
normal_stiffness = 1e5
[mill]
diameter = 0.3
length = 0.1
rpm = 30
charge = { count = 20, size = { distribution = "normal", mean = 0.01, std = 0.001, min = 0.009, max = 0.011 } }
[integrator]
dt = 1e-4
)",
    R"(
[scene]
dimension = 2
gravity = [0, -9.81, 0]
[[contacts]]
normal_stiffness = 1e5
[mill]
diameter = 0.3
critical_fraction = 0.5
charge = { filling = 0.1, size = { distribution = "lognormal", median = 0.01, sigma = 0.1, min = 0.009, max = 0.011 } }
[integrator]
dt = 1e-4
)"};

TEST(SceneKeys, TheLoaderAsksForEveryKeyOfItsSchema) {
  const SceneKeyRecorder recorder;
  std::vector<fs::path> files;
  for (const fs::path& dir : {source_dir / "scenes", source_dir / "tests" / "scenes"})
    for (const auto& entry : fs::directory_iterator(dir))
      if (entry.path().extension() == ".toml") files.push_back(entry.path());
  for (const fs::path& file : files) EXPECT_NO_THROW(load_scene(file.string())) << file;
  for (const char* text : branch_scenes) EXPECT_NO_THROW(load_scene_text(text, "branches.toml", source_dir.string())) << text;
  std::vector<std::string> never;
  for (const SceneKey& key : scene_keys())
    if (!recorder.keys().count(key.path)) never.push_back(key.path);
  EXPECT_TRUE(never.empty()) << "keys of the schema no scene here made the loader ask for (a key it no longer reads, "
                                "or a branch these scenes miss):"
                             << listed(never);
  for (const std::string& key : recorder.keys())
    EXPECT_TRUE(std::any_of(scene_keys().begin(), scene_keys().end(), [&](const SceneKey& k) { return k.path == key; }))
        << key;
}

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

// The 2D mill with and without a liner-liner entry (stiffer than its other entries): the same state,
// bit for bit. (Under step doubling the stiffest entry of all, met or not, still bounds the contact
// level, world_doubling.cpp; the entries the mill scenes dropped were no stiffer than the others.)
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
