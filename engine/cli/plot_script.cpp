#include "engine/cli/plot_script.h"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <vector>

namespace dem::cli {

namespace {

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::filesystem::path find_script(const std::string& script, const std::string& scene_file) {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates{fs::path("bench") / script,
                                   fs::absolute(scene_file).parent_path().parent_path() / "bench" / script};
#ifdef DEM_BENCH_DIR
  candidates.push_back(fs::path(DEM_BENCH_DIR) / script);
#endif
  for (const fs::path& p : candidates)
    if (fs::exists(p)) return p;
  return {};
}

}  // namespace

void run_plot_script(const char* program, const std::string& script, const std::string& scene_file,
                     const std::filesystem::path& csv, bool quiet) {
  namespace fs = std::filesystem;
  const fs::path path = find_script(script, scene_file);
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::string how = "apt-get install python3-matplotlib, then: python3 bench/" + script + " " + csv.string();
  if (path.empty()) {
    std::fprintf(stderr, "%s: bench/%s not found, no plot (from the source tree: %s)\n", program, script.c_str(), how.c_str());
    return;
  }
  const int has = std::system((python + " -c 'import matplotlib' >/dev/null 2>&1").c_str());
  if (!WIFEXITED(has) || WEXITSTATUS(has) != 0) {
    std::fprintf(stderr, "%s: Python 3 with matplotlib is missing, no plot; to plot: %s\n", program, how.c_str());
    return;
  }
  const std::string command = python + " " + quote(path.string()) + " " + quote(csv.string()) + (quiet ? " >/dev/null" : "");
  const int done = std::system(command.c_str());
  if (!WIFEXITED(done) || WEXITSTATUS(done) != 0)
    std::fprintf(stderr, "%s: %s failed; %s is complete\n", program, path.string().c_str(), csv.string().c_str());
}

}  // namespace dem::cli
