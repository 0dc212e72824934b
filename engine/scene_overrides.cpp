// `--set key=value` overrides (scene_overrides.h).
#include "engine/scene_overrides.h"

#include <sstream>
#include <vector>

#include "engine/input_error.h"

namespace dem::loader {
namespace {

/// Splits "a.b[2].c" into steps; a step is a key or an array index.
struct PathStep {
  std::string key;
  int index = -1;
};

std::vector<PathStep> parse_path(const std::string& path, const std::string& option) {
  std::vector<PathStep> steps;
  std::string token;
  std::istringstream in(path);
  while (std::getline(in, token, '.')) {
    PathStep step;
    const auto bracket = token.find('[');
    step.key = token.substr(0, bracket);
    if (step.key.empty()) throw InputError("--set", 0, 0, path, "empty key in '" + option + "'");
    steps.push_back(step);
    std::size_t pos = bracket;
    while (pos != std::string::npos) {
      const auto close = token.find(']', pos);
      if (close == std::string::npos) throw InputError("--set", 0, 0, path, "missing ']' in '" + option + "'");
      PathStep index;
      try {
        index.index = std::stoi(token.substr(pos + 1, close - pos - 1));
      } catch (...) {
        throw InputError("--set", 0, 0, path, "array index must be an integer in '" + option + "'");
      }
      steps.push_back(index);
      pos = token.find('[', close);
    }
  }
  return steps;
}

}  // namespace

void apply_override(toml::table& root, const std::string& option) {
  const auto eq = option.find('=');
  if (eq == std::string::npos || eq == 0) throw InputError("--set", 0, 0, "", "expected key.path=value, got '" + option + "'");
  const std::string path = option.substr(0, eq), text = option.substr(eq + 1);
  toml::table parsed;
  try {
    parsed = toml::parse("v = " + text);
  } catch (const toml::parse_error&) {
    parsed = toml::table{{"v", text}};
  }
  const std::vector<PathStep> steps = parse_path(path, option);
  toml::node* current = &root;
  for (std::size_t s = 0; s + 1 < steps.size(); ++s) {
    const PathStep& step = steps[s];
    if (step.index >= 0) {
      toml::array* a = current->as_array();
      if (!a || step.index >= static_cast<int>(a->size()))
        throw InputError("--set", 0, 0, path, "no array element [" + std::to_string(step.index) + "] on this path");
      current = a->get(static_cast<std::size_t>(step.index));
    } else {
      toml::table* t = current->as_table();
      if (!t) throw InputError("--set", 0, 0, path, "'" + step.key + "' is not inside a table");
      if (!t->contains(step.key)) t->insert(step.key, toml::table{});
      current = t->get(step.key);
    }
  }
  const PathStep& last = steps.back();
  toml::node& value = *parsed.get("v");
  if (last.index >= 0) {
    toml::array* a = current->as_array();
    if (!a || last.index >= static_cast<int>(a->size()))
      throw InputError("--set", 0, 0, path, "no array element [" + std::to_string(last.index) + "] on this path");
    a->replace(a->begin() + last.index, value);
  } else {
    toml::table* t = current->as_table();
    if (!t) throw InputError("--set", 0, 0, path, "'" + last.key + "' is not inside a table");
    t->insert_or_assign(last.key, value);
  }
}

}  // namespace dem::loader
