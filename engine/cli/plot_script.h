#pragma once
// Runs a plotting script `dem` ships (Debian's python3-matplotlib) on a CSV the program wrote, or
// says how to, when Python or matplotlib is missing: a PNG is a convenience, the CSV the result.
#include <filesystem>
#include <string>

namespace dem::cli {

/// The folder holding the plotting scripts. An installed `dem` (bin/dem beside share/dem) uses
/// <its own folder>/../share/dem/scripts, found from its own path (/proc/self/exe), so a moved or
/// copied prefix works and the source tree is never read; a `dem` in its build tree has no share/dem
/// beside it and uses bench/ of the source tree it was built from. Empty if neither exists.
std::filesystem::path plot_scripts_dir();

/// `python3 <plot_scripts_dir()>/<script> <csv>`. `program` prefixes the messages ("dem trade").
void run_plot_script(const char* program, const std::string& script, const std::filesystem::path& csv, bool quiet);

}  // namespace dem::cli
