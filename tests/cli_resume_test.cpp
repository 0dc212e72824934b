// Resume through the program: a run to T, resumed from its end checkpoint to 2T, equals a straight
// run to 2T bit for bit (state hash and series.csv bytes); a checkpoint of other physics is refused
// with exit code 2. A start from a checkpoint (--from) under another control writes fresh outputs
// from the checkpoint's time on.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "tests/cli_support.h"

namespace {

namespace fs = std::filesystem;
using dem::test::cli::read_text;

std::string hash_of(const fs::path& summary) { return dem::test::cli::summary_string(summary, "state_hash"); }

int run(const std::string& args, const std::string& scene = "tests/scenes/settle_small.toml") {
  return dem::test::cli::run_dem_status("run " + std::string(DEM_SOURCE_DIR) + "/" + scene + " --quiet " + args +
                                        " 2>/dev/null");
}

TEST(CliResume, ResumedRunEqualsStraightRunBitForBit) {
  const fs::path base = fs::temp_directory_path() / ("dem_resume_" + std::to_string(::getpid()));
  fs::remove_all(base);
  ASSERT_EQ(run("--until 0.3 --out " + (base / "straight").string()), 0);
  ASSERT_EQ(run("--until 0.15 --out " + (base / "split").string()), 0);
  fs::path checkpoint;
  for (const auto& e : fs::directory_iterator(base / "split"))
    if (e.path().filename().string().rfind("checkpoint_", 0) == 0) checkpoint = e.path();
  ASSERT_FALSE(checkpoint.empty()) << "a run writes a checkpoint at its end";
  const dem::test::cli::Json first_half = dem::test::cli::read_json(base / "split" / "summary.json");
  ASSERT_EQ(run("--until 0.3 --out " + (base / "split").string() + " --resume " + checkpoint.string()), 0);
  // The counters go on from the checkpoint; the rate counts this invocation's steps only.
  const dem::test::cli::Json whole = dem::test::cli::read_json(base / "straight" / "summary.json");
  const dem::test::cli::Json second_half = dem::test::cli::read_json(base / "split" / "summary.json");
  EXPECT_EQ(second_half["counters"]["particle_steps"].number, whole["counters"]["particle_steps"].number);
  EXPECT_EQ(first_half["run_particle_steps"].number, first_half["counters"]["particle_steps"].number);
  EXPECT_EQ(second_half["run_particle_steps"].number,
            whole["counters"]["particle_steps"].number - first_half["counters"]["particle_steps"].number);
  EXPECT_GT(second_half["run_particle_steps"].number, 0);
  EXPECT_NEAR(second_half["particle_steps_per_second"].number * second_half["wall_time"].number,
              second_half["run_particle_steps"].number, 1e-6 * second_half["run_particle_steps"].number);

  EXPECT_EQ(hash_of(base / "split" / "summary.json"), hash_of(base / "straight" / "summary.json"));
  EXPECT_FALSE(hash_of(base / "straight" / "summary.json").empty());
  EXPECT_EQ(read_text(base / "split" / "series.csv"), read_text(base / "straight" / "series.csv"));
  EXPECT_EQ(read_text(base / "split" / "walls.csv"), read_text(base / "straight" / "walls.csv"));

  // Other physics: refused as bad input, and the outputs stay as they were.
  const std::string series_before = read_text(base / "split" / "series.csv");
  EXPECT_EQ(run("--until 0.4 --out " + (base / "split").string() + " --resume " + checkpoint.string() +
                " --set contacts[0].normal_stiffness=2e5"),
            2);
  EXPECT_EQ(read_text(base / "split" / "series.csv"), series_before);
  fs::remove_all(base);
}

TEST(CliResume, AStartFromACheckpointRunsUnderAnotherControl) {
  const fs::path base = fs::temp_directory_path() / ("dem_from_" + std::to_string(::getpid()));
  fs::remove_all(base);
  ASSERT_EQ(run("--until 0.15 --out " + (base / "fixed").string()), 0);
  fs::path checkpoint;
  for (const auto& e : fs::directory_iterator(base / "fixed"))
    if (e.path().filename().string().rfind("checkpoint_", 0) == 0) checkpoint = e.path();
  ASSERT_FALSE(checkpoint.empty());
  const double t0 = dem::test::cli::read_json(base / "fixed" / "summary.json")["time"].number;
  const std::string doubling = " --set integrator.control=doubling --set integrator.tolerance=1e-3";
  // A resume needs the same integrator settings; other physics is refused by a start too.
  EXPECT_EQ(run("--until 0.2 --out " + (base / "refused").string() + " --resume " + checkpoint.string() + doubling), 2);
  EXPECT_EQ(run("--until 0.2 --out " + (base / "refused").string() + " --from " + checkpoint.string() +
                " --set contacts[0].normal_stiffness=2e5"),
            2);
  EXPECT_NE(run("--until 0.2 --out " + (base / "refused").string() + " --from " + checkpoint.string() + " --resume " +
                checkpoint.string()),
            0);
  ASSERT_EQ(run("--until 0.2 --out " + (base / "doubling").string() + " --from " + checkpoint.string() + doubling), 0);
  const dem::test::cli::Json summary = dem::test::cli::read_json(base / "doubling" / "summary.json");
  EXPECT_GE(summary["time"].number, 0.2);
  EXPECT_EQ(summary["settings"]["control"].string, "doubling");
  // The counters are this run's alone; the energy books go on from the checkpoint's.
  EXPECT_EQ(summary["run_particle_steps"].number, summary["counters"]["particle_steps"].number);
  EXPECT_GT(summary["counters"]["accepted_steps"].number, 0);
  const dem::test::cli::Json fixed = dem::test::cli::read_json(base / "fixed" / "summary.json");
  EXPECT_EQ(summary["start"]["dissipated_energy"].number, fixed["end"]["dissipated_energy"].number);
  // series.csv is this run's: its first row at the checkpoint's time.
  const std::string series = read_text(base / "doubling" / "series.csv");
  const std::size_t first_row = series.find('\n') + 1;
  ASSERT_LT(first_row, series.size());
  EXPECT_DOUBLE_EQ(std::stod(series.substr(first_row)), t0);
  fs::remove_all(base);
}

TEST(CliResume, AResumedMillContinuesItsRevolutionsAndSpectra) {
  // Split mid-revolution: the power per revolution, the steady mean and the spectra carry over.
  const std::string mill = "tests/scenes/mill_small.toml";
  const fs::path base = fs::temp_directory_path() / ("dem_resume_mill_" + std::to_string(::getpid()));
  fs::remove_all(base);
  const std::string whole = "--until 1.8 --set mill.discard_revolutions=0 --out ";
  ASSERT_EQ(run(whole + (base / "straight").string(), mill), 0);
  ASSERT_EQ(run("--until 1.3 --set mill.discard_revolutions=0 --out " + (base / "split").string(), mill), 0);
  fs::path checkpoint;
  for (const auto& e : fs::directory_iterator(base / "split"))
    if (e.path().filename().string().rfind("checkpoint_", 0) == 0) checkpoint = e.path();
  ASSERT_FALSE(checkpoint.empty());
  ASSERT_EQ(run(whole + (base / "split").string() + " --resume " + checkpoint.string(), mill), 0);
  for (const char* file : {"mill.csv", "mill_revolutions.csv", "spectra.csv", "series.csv"})
    EXPECT_TRUE(read_text(base / "split" / file) == read_text(base / "straight" / file)) << file << " differs";
  const std::string summary = read_text(base / "split" / "summary.json");
  const auto mean = [](const std::string& text) { return text.substr(text.find("\"mean_power_draw\"")); };
  ASSERT_NE(summary.find("\"mean_power_draw\""), std::string::npos);
  EXPECT_EQ(mean(summary).substr(0, 40), mean(read_text(base / "straight" / "summary.json")).substr(0, 40));
  fs::remove_all(base);
}

}  // namespace

namespace {

TEST(CliResume, RunKilledMidwayResumesFromItsLastCheckpointToTheSameHash) {
  const fs::path base = fs::temp_directory_path() / ("dem_kill_" + std::to_string(::getpid()));
  fs::remove_all(base);
  ASSERT_EQ(run("--until 0.35 --out " + (base / "straight").string()), 0);
  // Start a run with periodic checkpoints and kill it (SIGKILL) once one exists and before the end.
  const fs::path killed = base / "killed";
  fs::create_directories(killed);
  const std::string command = std::string(DEM_PROGRAM) + " run " + DEM_SOURCE_DIR +
                              "/tests/scenes/settle_small.toml --quiet --until 0.35 --checkpoint-every 0.02 --out " +
                              killed.string() + " 2>/dev/null & echo $!";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  int pid = 0;
  ASSERT_EQ(std::fscanf(pipe, "%d", &pid), 1);
  ::pclose(pipe);
  fs::path checkpoint;
  for (int wait = 0; wait < 2000 && checkpoint.empty(); ++wait) {
    for (const auto& e : fs::directory_iterator(killed))
      if (e.path().extension() == ".bin") checkpoint = e.path();
    if (checkpoint.empty()) ::usleep(1000);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
  ASSERT_FALSE(checkpoint.empty()) << "no checkpoint appeared";
  ASSERT_FALSE(fs::exists(killed / "summary.json")) << "the run finished before it could be killed";
  // The newest complete checkpoint (a file being written has a temporary name).
  for (const auto& e : fs::directory_iterator(killed))
    if (e.path().extension() == ".bin") checkpoint = e.path();
  // Every output file is whole: the series parses to the end of its last line.
  const std::string series = read_text(killed / "series.csv");
  ASSERT_FALSE(series.empty());
  ASSERT_EQ(run("--until 0.35 --out " + killed.string() + " --resume " + checkpoint.string()), 0);
  EXPECT_EQ(hash_of(killed / "summary.json"), hash_of(base / "straight" / "summary.json"));
  EXPECT_EQ(read_text(killed / "series.csv"), read_text(base / "straight" / "series.csv"));
  fs::remove_all(base);
}

// Times of the entries of a .pvd index.
std::vector<double> pvd_times(const fs::path& pvd) {
  const std::string text = read_text(pvd);
  std::vector<double> times;
  const std::string key = "timestep=\"";
  for (std::size_t at = text.find(key); at != std::string::npos; at = text.find(key, at + 1))
    times.push_back(std::stod(text.substr(at + key.size())));
  return times;
}

TEST(CliResume, AResumedRunWithoutTheContactNetworkCutsTheEarlierRunsIndexAtTheCheckpoint) {
  const fs::path base = fs::temp_directory_path() / ("dem_resume_contacts_" + std::to_string(::getpid()));
  fs::remove_all(base);
  const std::string out = " --out " + (base / "run").string();
  const std::string snapshots = " --set output.snapshot_interval=0.05";
  ASSERT_EQ(run("--until 0.15 --set output.contacts=true" + snapshots + out), 0);
  fs::path checkpoint;
  for (const auto& e : fs::directory_iterator(base / "run"))
    if (e.path().filename().string().rfind("checkpoint_", 0) == 0) checkpoint = e.path();
  ASSERT_FALSE(checkpoint.empty());
  const fs::path kept = base / "checkpoint.bin";
  fs::copy_file(checkpoint, kept);
  // The run that went on to 0.3 and died there: its contact network reaches past the checkpoint.
  ASSERT_EQ(run("--until 0.3 --set output.contacts=true" + snapshots + out + " --resume " + kept.string()), 0);
  const std::vector<double> before = pvd_times(base / "run" / "contacts.pvd");
  ASSERT_FALSE(before.empty());
  ASSERT_GT(before.back(), 0.2);
  // Resumed from 0.15 without the network: its index keeps only what 0.15 covers.
  ASSERT_EQ(run("--until 0.3 --set output.contacts=false" + snapshots + out + " --resume " + kept.string()), 0);
  const std::vector<double> after = pvd_times(base / "run" / "contacts.pvd");
  ASSERT_FALSE(after.empty()) << "the snapshots up to the checkpoint stay listed";
  for (const double t : after) EXPECT_LE(t, 0.15 + 1e-9) << "an entry of the run that died after the checkpoint";
  fs::remove_all(base);
}

}  // namespace
