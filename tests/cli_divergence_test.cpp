// The energy audit stops an unstable run: the seed slope with velocity Verlet at dt = 0.1 s
// (omega0 dt = 2.24 > 2, beyond the Cundall-Strack limit, docs/physics.md 4.2) gains energy from nowhere
// and must end with exit code 3 and a diagnosis, not finish quietly with nonsense; the same scene at
// its own dt passes the audit. Every way out of a run that writes results is audited first.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

#include "tests/cli_support.h"

namespace {

namespace fs = std::filesystem;
using dem::test::cli::checkpoints_in;
using dem::test::cli::read_text;

/// Runs `dem run` on a scene (path from the source root), stderr to `out`.err; returns the exit code.
int run_scene(const std::string& scene, const std::string& args, const fs::path& out) {
  return dem::test::cli::run_dem_status("run " + std::string(DEM_SOURCE_DIR) + "/" + scene + " --quiet " + args +
                                        " --out " + out.string() + " 2>" + (out.string() + ".err"));
}

int run(const std::string& args, const fs::path& out) { return run_scene("scenes/seed_slope.toml", args, out); }

/// A scratch folder for one test, removed by the test when it passes.
fs::path scratch(const std::string& name) {
  const fs::path base = fs::temp_directory_path() / ("dem_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(base);
  fs::create_directories(base);
  return base;
}

TEST(CliDivergence, VerletBeyondTheStabilityLimitStopsWithExitThree) {
  const fs::path base = fs::temp_directory_path() / ("dem_diverge_" + std::to_string(::getpid()));
  fs::remove_all(base);
  fs::create_directories(base);
  EXPECT_EQ(run("--set integrator.dt=0.1", base / "unstable"), 3);
  const std::string err = read_text(base / "unstable.err");
  EXPECT_NE(err.find("energy grew"), std::string::npos) << err;
  EXPECT_NE(err.find("integrator.dt"), std::string::npos) << "the message names the setting to change";
  EXPECT_NE(read_text(base / "unstable" / "summary.json").find("\"status\": \"diverged\""), std::string::npos);
  EXPECT_NE(err.find("particle 0"), std::string::npos) << "the message names the particle";
  // The last good state is kept as a checkpoint, and resuming it with a stable step works.
  fs::path good;
  for (const auto& e : fs::directory_iterator(base / "unstable"))
    if (e.path().extension() == ".bin") good = e.path();
  ASSERT_FALSE(good.empty()) << "no checkpoint of the last good state";
  EXPECT_EQ(run("--set integrator.dt=0.1 --until 0.0001 --resume " + good.string(), base / "resumed"), 0);

  EXPECT_EQ(run("", base / "stable"), 0) << read_text(base / "stable.err");
  EXPECT_EQ(read_text(base / "stable.err").find("warning"), std::string::npos) << read_text(base / "stable.err");
  fs::remove_all(base);
}

TEST(CliDivergence, AStepBeyondTheStabilityLimitIsWarnedAtLoadAndDoublingAdapts) {
  const fs::path base = scratch("warn");
  EXPECT_EQ(run("--set integrator.dt=0.1 --until 0.05", base / "fixed"), 0);  // stopped before it diverges
  const std::string err = read_text(base / "fixed.err");
  EXPECT_NE(err.find("warning: dt = 0.1 s exceeds the stability limit"), std::string::npos) << err;
  EXPECT_NE(err.find("integrator.dt"), std::string::npos) << "the warning names the setting to change";
  // The same step as the base of step doubling: its finest level is stable, so no warning, and the
  // run completes (the control adapts the step where the contact needs it).
  EXPECT_EQ(run("--set integrator.dt=0.1 --set integrator.control=doubling", base / "doubling"), 0)
      << read_text(base / "doubling.err");
  EXPECT_EQ(read_text(base / "doubling.err").find("warning"), std::string::npos) << read_text(base / "doubling.err");
  // Doubling whose finest step is still beyond the limit is warned too, naming level_min.
  EXPECT_EQ(run("--set integrator.dt=0.1 --set integrator.control=doubling --set integrator.level_min=0 --until 0.05",
                base / "coarse"),
            0);
  EXPECT_NE(read_text(base / "coarse.err").find("integrator.level_min"), std::string::npos) << read_text(base / "coarse.err");
  fs::remove_all(base);
}

// A predicted dashpot (integrator.predicted_dashpot) tightens the limit to omega0 h < 2 (sqrt(1 +
// 4 zeta^2) - 2 zeta) (engine/forces.h): on the seed slope (omega0 = 22.36 1/s, zeta = 0.2) 0.0606 s
// instead of 0.0733 s, so dt = 0.065 s is warned with it and not without.
TEST(CliDivergence, PredictedDashpotIsWarnedAtItsOwnTighterLimit) {
  const fs::path base = scratch("predicted");
  EXPECT_EQ(run("--set integrator.dt=0.065 --until 0.2", base / "half_step"), 0);
  EXPECT_EQ(read_text(base / "half_step.err").find("warning"), std::string::npos) << read_text(base / "half_step.err");
  EXPECT_EQ(run("--set integrator.dt=0.065 --set integrator.predicted_dashpot=true --until 0.2", base / "predicted"), 0);
  EXPECT_NE(read_text(base / "predicted.err").find("exceeds the stability limit 0.06056 s"), std::string::npos)
      << read_text(base / "predicted.err");
  fs::remove_all(base);
}

// With an output interval longer than the run no row falls due before the end: the final row, and
// the settle workflow's stop on low kinetic energy (which writes settled.csv), must still be audited.
TEST(CliDivergence, FinalRowAndSettleStopAreAudited) {
  const fs::path base = scratch("final_audit");
  const std::string unstable = "--set integrator.dt=0.1 --set output.interval=100 --set output.snapshot_interval=0";
  EXPECT_EQ(run(unstable, base / "final"), 3);
  const std::string err = read_text(base / "final.err");
  EXPECT_NE(err.find("diverged at t = 8 s"), std::string::npos) << err;
  EXPECT_NE(err.find("particle 0"), std::string::npos) << err;
  EXPECT_NE(err.find("integrator.dt"), std::string::npos) << err;
  EXPECT_NE(read_text(base / "final" / "summary.json").find("\"status\": \"diverged\""), std::string::npos);
  // No audit passed after the start, so the start is the last good state.
  EXPECT_NE(err.find("(t = 0 s)"), std::string::npos) << err;
  EXPECT_TRUE(fs::exists(base / "final" / "checkpoint_0.bin"));
  EXPECT_EQ(checkpoints_in(base / "final").size(), 1u);

  EXPECT_EQ(run(unstable + " --set run.stop_kinetic_energy=1e9 --set run.stop_check_after=6 --set output.settled_file=settled.csv",
                base / "settle"),
            3);
  EXPECT_NE(read_text(base / "settle.err").find("diverged at t = 6 s"), std::string::npos) << read_text(base / "settle.err");
  EXPECT_FALSE(fs::exists(base / "settle" / "settled.csv")) << "a diverged state is not a settled bed";
  if (!HasFailure()) fs::remove_all(base);
}

// A blow-up late in a run is judged against the energy in play since the last good audit, not
// against everything dissipated since the start (tests/scenes/late_blowup.toml: 0.33 J from nowhere
// at t = 1.001 s, after some 25 J were dissipated, when 0.07 J were in play).
TEST(CliDivergence, LateBlowUpIsNotHiddenByEnergyDissipatedEarlier) {
  const fs::path base = scratch("late");
  EXPECT_EQ(run_scene("tests/scenes/late_blowup.toml", "", base / "late"), 3);
  const std::string err = read_text(base / "late.err");
  EXPECT_NE(err.find("diverged at t = 1.1 s: the energy grew"), std::string::npos) << err;
  EXPECT_TRUE(err.find("particle 2") != std::string::npos || err.find("particle 3") != std::string::npos)
      << "the message names a particle of the unstable pair: " << err;
  EXPECT_NE(err.find("The last good state (t = 1 s)"), std::string::npos) << err;
  // Before the blow-up the same scene is sound.
  EXPECT_EQ(run_scene("tests/scenes/late_blowup.toml", "--until 1", base / "before"), 0) << read_text(base / "before.err");
  if (!HasFailure()) fs::remove_all(base);
}

// Periodic checkpoints written after the last good audit hold a state no audit has passed: when the
// run diverges they are removed, and the one checkpoint left is that of the last good state.
TEST(CliDivergence, DivergedRunLeavesOnlyTheLastGoodCheckpoint) {
  const fs::path base = scratch("checkpoints");
  // Rows every 0.1 s, checkpoints every 0.04 s: the blow-up at 1.001 s is found at 1.1 s, after
  // checkpoints at 1.04 and 1.08 s.
  EXPECT_EQ(run_scene("tests/scenes/late_blowup.toml", "--checkpoint-every 0.04", base / "late"), 3);
  const std::string err = read_text(base / "late.err");
  EXPECT_NE(err.find("The last good state (t = 1 s) is in " + (base / "late" / "checkpoint_1.bin").string()), std::string::npos)
      << err;
  const std::vector<fs::path> left = checkpoints_in(base / "late");
  std::string names;
  for (const fs::path& p : left) names += " " + p.filename().string();
  ASSERT_EQ(left.size(), 1u) << "checkpoints left:" << names;
  EXPECT_EQ(left[0].filename(), "checkpoint_1.bin");
  EXPECT_EQ(run_scene("tests/scenes/late_blowup.toml", "--until 1 --resume " + left[0].string(), base / "resumed"), 0)
      << read_text(base / "resumed.err");
  if (!HasFailure()) fs::remove_all(base);
}

// An impact too fast for the stiffness (head_on with k = 100 N/m: the linear law's overlap would be
// v / omega0 = 1.4 R) goes deeper than the law describes between two result rows; the overlap is
// watched at every step, so the run stops with exit code 3 and names the pair, the depth and what
// to change, keeping the last good state.
TEST(CliDivergence, AnImpactDeeperThanHalfTheRadiusStopsTheRun) {
  const fs::path base = scratch("deep");
  const std::string soft = "--set contacts[0].normal_stiffness=100 --until 0.2 --set output.interval=0.05";
  EXPECT_EQ(run_scene("scenes/head_on.toml", soft, base / "deep"), 3);
  const std::string err = read_text(base / "deep.err");
  EXPECT_NE(err.find("particles 0 and 1 overlapped by"), std::string::npos) << err;
  EXPECT_NE(err.find("normal_stiffness"), std::string::npos) << "the message names the setting to change: " << err;
  EXPECT_EQ(checkpoints_in(base / "deep").size(), 1u);
  // Stiff enough (the shipped k = 1e5 N/m: 0.045 R), the same run is sound.
  EXPECT_EQ(run_scene("scenes/head_on.toml", "--until 0.2 --set output.interval=0.05", base / "stiff"), 0)
      << read_text(base / "stiff.err");
  if (!HasFailure()) fs::remove_all(base);
}

// A fixed Verlet step that carries a particle further than its radius can step over a contact: the
// run warns, naming the particle, the travel per step and a step that would not.
TEST(CliDivergence, AStepLongerThanTheParticleIsWarnedOf) {
  const fs::path base = scratch("travel");
  // head_on with the spheres flying apart at 0.5 m/s, R = 5 cm: dt = 0.2 s carries each 2 radii per step.
  const std::string apart = "--set particles[0].velocity=[-0.5,0,0] --set particles[1].velocity=[0.5,0,0] ";
  EXPECT_EQ(run_scene("scenes/head_on.toml", apart + "--set integrator.dt=0.2 --until 1 --set output.interval=0.2", base / "long"), 0);
  const std::string err = read_text(base / "long.err");
  EXPECT_NE(err.find("warning: particle 0 moves 2 of its radii per step"), std::string::npos) << err;
  EXPECT_NE(err.find("integrator.dt below 0.1 s"), std::string::npos) << err;
  const std::string summary = read_text(base / "long" / "summary.json");
  EXPECT_NE(summary.find("\"longest_step_travel\": 2"), std::string::npos) << summary;
  // At the scene's own step (5e-6 m per step, 1e-4 radii) there is no warning.
  EXPECT_EQ(run_scene("scenes/head_on.toml", "--until 0.001", base / "short"), 0);
  EXPECT_EQ(read_text(base / "short.err").find("warning: particle"), std::string::npos) << read_text(base / "short.err");
  if (!HasFailure()) fs::remove_all(base);
}

}  // namespace
