#include "engine/cli/plot_script.h"

#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <system_error>

namespace dem::cli {

namespace {

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

std::filesystem::path plot_scripts_dir() {
  namespace fs = std::filesystem;
  std::error_code error;
#ifdef DEM_SHARE_FROM_BIN
  // The installed layout: share/dem at DEM_SHARE_FROM_BIN (GNUInstallDirs' datadir/dem relative to
  // its bindir, "../share/dem" by default) from the folder of the executable itself.
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  if (!error) {
    const fs::path share = (exe.parent_path() / DEM_SHARE_FROM_BIN).lexically_normal();
    if (fs::is_directory(share, error)) return share / "scripts";
  }
#endif
#ifdef DEM_BENCH_DIR
  // A build-tree program: the plotting scripts of the source tree it was built from.
  if (fs::is_directory(DEM_BENCH_DIR, error)) return DEM_BENCH_DIR;
#endif
  return {};
}

void run_plot_script(const char* program, const std::string& script, const std::filesystem::path& csv, bool quiet) {
  namespace fs = std::filesystem;
  const fs::path dir = plot_scripts_dir();
  const fs::path path = dir.empty() ? fs::path(script) : dir / script;
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::string how = "apt-get install python3-matplotlib, then: python3 " + path.string() + " " + csv.string();
  if (dir.empty() || !fs::exists(path)) {
    std::fprintf(stderr, "%s: %s not found, no plot\n", program,
                 dir.empty() ? ("share/dem/scripts/" + script + " (beside the program) or bench/" + script).c_str()
                             : path.string().c_str());
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
