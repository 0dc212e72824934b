// The energy audit stops an unstable run: the seed slope with velocity Verlet at dt = 0.1 s
// (omega0 dt = 2.24 > 2, beyond the Cundall-Strack limit, PHYSICS.md 2) gains energy from nowhere
// and must end with exit code 3 and a diagnosis, not finish quietly with nonsense; the same scene at
// its own dt passes the audit.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>
#include <unistd.h>

namespace {

namespace fs = std::filesystem;

int run(const std::string& args, const fs::path& out) {
  const std::string command = std::string(DEM_PROGRAM) + " run " + DEM_SOURCE_DIR + "/scenes/seed_slope.toml --quiet " +
                              args + " --out " + out.string() + " 2>" + (out.string() + ".err");
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(CliDivergence, VerletBeyondTheStabilityLimitStopsWithExitThree) {
  const fs::path base = fs::temp_directory_path() / ("dem_diverge_" + std::to_string(::getpid()));
  fs::remove_all(base);
  fs::create_directories(base);
  EXPECT_EQ(run("--set integrator.dt=0.1", base / "unstable"), 3);
  const std::string err = read(base / "unstable.err");
  EXPECT_NE(err.find("energy grew"), std::string::npos) << err;
  EXPECT_NE(err.find("integrator.dt"), std::string::npos) << "the message names the setting to change";
  EXPECT_NE(read(base / "unstable" / "summary.json").find("\"status\": \"diverged\""), std::string::npos);
  EXPECT_NE(err.find("particle 0"), std::string::npos) << "the message names the particle";
  // The last good state is kept as a checkpoint, and resuming it with a stable step works.
  fs::path good;
  for (const auto& e : fs::directory_iterator(base / "unstable"))
    if (e.path().extension() == ".bin") good = e.path();
  ASSERT_FALSE(good.empty()) << "no checkpoint of the last good state";
  EXPECT_EQ(run("--set integrator.dt=0.1 --until 0.0001 --resume " + good.string(), base / "resumed"), 0);

  EXPECT_EQ(run("", base / "stable"), 0) << read(base / "stable.err");
  fs::remove_all(base);
}

}  // namespace
