// libFuzzer target for the scene loader. Feeds each input to load_scene_text as the
// text of a scene file. Bad input must come back as dem::InputError, the one exception the loader
// documents; anything else (a crash, a sanitizer report, another exception, a hang, a runaway
// allocation) is a finding. Built and run by scripts/fuzz.sh.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <toml++/toml.h>

#include "engine/input_error.h"
#include "engine/scene_loader.h"

namespace {

// Relative particle files resolve against a folder that does not exist, so every [[particle_files]]
// entry is "file not found" and inputs do not depend on the machine's files.
constexpr const char* base_dir = "/nonexistent/dem-fuzz";

// An absolute path into a device or pseudo-file tree (/dev/zero, /dev/stdin, /proc/...) would make the
// CSV reader block or read without end: a property of the host, not of the loader. Such inputs are
// skipped.
bool names_special_file(std::string_view text) {
  for (std::string_view prefix : {"/dev", "/proc", "/sys"})
    if (text.find(prefix) != std::string_view::npos) return true;
  return false;
}

// [[generators]] place `count` particles with up to `max_attempts` tries each: legitimate work that
// grows without bound (the shipped settle_bed.toml, 20,000 particles, takes 3 s under the
// sanitizers). Inputs asking for more than these budgets are skipped, so a slow input is a finding
// and not a large but valid scene; generation itself is tested in tests/.
constexpr std::int64_t max_generated = 2000;         // particles, over all generators
constexpr std::int64_t max_placement_tries = 200000;  // count * max_attempts, over all generators

bool generates_too_much(const std::string& text) {
  toml::table root;
  try {
    root = toml::parse(text);
  } catch (const toml::parse_error&) {
    return false;  // the loader reports the syntax error
  }
  const toml::array* generators = root["generators"].as_array();
  std::int64_t count = 0, tries = 0;
  static const toml::array none;
  for (const toml::node& node : generators ? *generators : none) {
    const toml::table* g = node.as_table();
    if (!g) continue;
    const std::int64_t n = (*g)["count"].value_exact<std::int64_t>().value_or(0);
    const std::int64_t a = (*g)["max_attempts"].value_exact<std::int64_t>().value_or(1000);
    // Clamped so the sums cannot overflow; value_exact, because toml++'s value<int64_t>() converts
    // a float out of range with undefined behaviour (found by this target).
    count += std::clamp<std::int64_t>(n, 0, max_generated + 1);
    tries += std::clamp<std::int64_t>(n, 0, max_generated + 1) * std::clamp<std::int64_t>(a, 0, max_placement_tries + 1);
  }
  // A [mill] charge is a generator too: `count` balls, or as many as `filling` of the mill holds.
  if (const toml::table* charge = root["mill"]["charge"].as_table()) {
    double n = static_cast<double>((*charge)["count"].value_exact<std::int64_t>().value_or(0));
    if (const auto filling = (*charge)["filling"].value<double>()) {
      const double d = root["mill"]["diameter"].value<double>().value_or(1);
      const double r = (*charge)["size"]["radius"].value<double>().value_or(
          (*charge)["size"]["min"].value<double>().value_or(1e-300));
      const double length = root["mill"]["length"].value<double>().value_or(2 * r);
      n = *filling * d * d * length / (r * r * r);  // over-estimates what the loader places
    }
    const double a = static_cast<double>((*charge)["max_attempts"].value_exact<std::int64_t>().value_or(1000));
    if (!(n <= static_cast<double>(max_generated))) return true;  // NaN and huge included
    n = std::max(n, 0.0);  // a negative filling or count places nothing (the loader rejects it)
    count += static_cast<std::int64_t>(n);
    tries += static_cast<std::int64_t>(n * std::clamp(a, 0.0, static_cast<double>(max_placement_tries + 1)));
  }
  return count > max_generated || tries > max_placement_tries;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  if (names_special_file(text) || generates_too_much(text)) return -1;  // -1: keep it out of the corpus
  try {
    (void)dem::load_scene_text(text, "fuzz.toml", base_dir);
  } catch (const dem::InputError&) {
    // Rejected with a message: the expected outcome for bad input.
  }
  return 0;
}
