#pragma once
// Runs a plotting script of bench/ (Debian's python3-matplotlib) on a CSV the program wrote, or
// says how to, when Python or matplotlib is missing: a PNG is a convenience, the CSV the result.
#include <filesystem>
#include <string>

namespace dem::cli {

/// `python3 bench/<script> <csv>`; the script is looked for in ./bench, beside the scene's folder and
/// in the source tree the program was built from. `program` prefixes the messages ("dem trade").
void run_plot_script(const char* program, const std::string& script, const std::string& scene_file,
                     const std::filesystem::path& csv, bool quiet);

}  // namespace dem::cli
