// `dem trade` from the outside (run through std::system as a user would; only exit codes, messages and
// files are looked at):
//  - trade.csv has the documented columns and one row per setting (head_on, docs/physics.md 8.2);
//  - fixed velocity Verlet is second order: on a sphere oscillating on a plane wall (never separating, so
//    no contact events) halving dt divides the trajectory error by about 4;
//  - an unstable fixed step (seed slope at dt = 0.1 s, omega0 dt > 2) is a `diverged` row with infinite
//    errors, and the command still exits 0;
//  - malformed options and [accuracy] metrics are rejected with exit code 2 and a message naming them;
//  - the reference check: a reference that diverges exits 1; a reference that is not converged (head_on's
//    damped contact onset makes Verlet first order) is reported; a converged one is marked so;
//  - a reference loaded from the reference.csv of an earlier run gives the same errors;
//  - observables get a noise floor from perturbed reference runs;
//  - a mill is measured by its power draw and collision spectrum under both controls;
//  - with --from every run starts from a warmed checkpoint and the metrics count from its time;
//  - the recommendation.csv agrees with trade.csv (the choice recomputed here from its rows), a target
//    replaces the noise floor, diverged rows are never chosen, and bad --target items exit 2.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli_trade_support.h"

namespace {

using namespace dem::test::trade_cli;

const std::vector<std::string> trajectory_errors = {"position_max_error", "position_rms_error", "velocity_max_error",
                                                    "velocity_rms_error"};

/// A 1 kg sphere resting on a plane under gravity, released from half its equilibrium overlap without
/// damping: it oscillates (omega = 100 rad/s) between 0.5 and 1.5 times the equilibrium overlap and never
/// leaves the wall, so the motion is smooth and Verlet's global error is C dt^2.
void write_oscillator(const fs::path& path) {
  std::ofstream(path) << R"([scene]
gravity = [0.0, 0.0, -9.81]
max_initial_overlap = 0.05
[[contacts]]
normal_stiffness = 1e4
normal_damping = { damping_ratio = 0.0 }
[[walls]]
type = "plane"
[[particles]]
position = [0.0, 0.0, 0.0495095]
radius = 0.05
mass = 1.0
[integrator]
dt = 1e-3
[run]
until = 0.1
[output]
interval = 0.01
)";
}

TEST(CliTrade, WritesOneRowPerSettingWithTheDocumentedColumns) {
  TempDir dir;
  const Result r = trade("scenes/head_on.toml --fixed 1e-4,5e-5 --tol 1e-2,1e-3 --no-plot --out " + dir.path().string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "trade.csv");
  std::vector<std::string> expected = {"control",     "method",    "dt", "tolerance", "wall_time", "particle_steps",
                                       "force_evaluations", "rejected_steps", "status"};
  expected.insert(expected.end(), trajectory_errors.begin(), trajectory_errors.end());
  EXPECT_EQ(csv.header, expected);
  ASSERT_EQ(csv.rows.size(), 4u);
  EXPECT_EQ(csv.rows[0].at("control"), "fixed");
  EXPECT_EQ(csv.rows[1].at("control"), "fixed");
  EXPECT_EQ(csv.rows[2].at("control"), "doubling");
  EXPECT_EQ(csv.rows[3].at("control"), "doubling");
  EXPECT_DOUBLE_EQ(csv.number(0, "dt"), 1e-4);
  EXPECT_DOUBLE_EQ(csv.number(1, "dt"), 5e-5);
  EXPECT_DOUBLE_EQ(csv.number(2, "tolerance"), 1e-2);
  EXPECT_DOUBLE_EQ(csv.number(3, "tolerance"), 1e-3);
  for (std::size_t k = 0; k < csv.rows.size(); ++k) {
    EXPECT_EQ(csv.rows[k].at("method"), "verlet");
    EXPECT_EQ(csv.rows[k].at("status"), "ok");
    EXPECT_GT(csv.number(k, "particle_steps"), 0);
    EXPECT_GE(csv.number(k, "force_evaluations"), csv.number(k, "particle_steps") / 2);
    for (const std::string& e : trajectory_errors) {
      EXPECT_GT(csv.number(k, e), 0) << e;
      EXPECT_LT(csv.number(k, e), 1e-2) << e;
    }
  }
  // 2 particles, 0.02 s at 1e-4 s: 400 particle-steps; half the step, twice the cost.
  EXPECT_EQ(csv.number(0, "particle_steps"), 400);
  EXPECT_EQ(csv.number(1, "particle_steps"), 800);
  // The metrics are stated: in the output and in trade_metrics.txt, one row per error column.
  EXPECT_NE(r.out.find("metrics: position_max, position_rms, velocity_max, velocity_rms"), std::string::npos) << r.out;
  const Csv metrics = read_csv(dir.path() / "trade_metrics.txt");
  ASSERT_EQ(metrics.rows.size(), 4u);
  EXPECT_EQ(metrics.rows[0].at("metric"), "position_max");
  EXPECT_EQ(metrics.rows[0].at("unit"), "m");
  EXPECT_EQ(metrics.rows[2].at("unit"), "m/s");
  EXPECT_TRUE(fs::exists(dir.path() / "reference.csv"));
}

TEST(CliTrade, FixedVerletErrorFallsAsDtSquared) {
  TempDir dir;
  write_oscillator(dir.path() / "oscillator.toml");
  const Result r = trade((dir.path() / "oscillator.toml").string() + " --fixed 2e-3,1e-3 --no-plot --out " +
                             (dir.path() / "out").string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "out" / "trade.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  for (const std::string& e : trajectory_errors) {
    const double ratio = csv.number(0, e) / csv.number(1, e);
    EXPECT_GT(ratio, 3.5) << e;  // 4 for an order-2 method
    EXPECT_LT(ratio, 4.5) << e;
  }
  // The reference (dt / 8) is converged for these errors: 64 times smaller than the finer one's.
  const Csv metrics = read_csv(dir.path() / "out" / "trade_metrics.txt");
  for (const auto& row : metrics.rows) EXPECT_EQ(row.at("reference_converged"), "yes") << row.at("metric");
  EXPECT_EQ(r.err.find("did not converge"), std::string::npos) << r.err;
}

TEST(CliTrade, UnstableStepIsADivergedRowAndExitsZero) {
  TempDir dir;
  const Result r = trade("scenes/seed_slope.toml --fixed 0.1,0.01 --no-plot --out " + dir.path().string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "trade.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  EXPECT_EQ(csv.rows[0].at("status"), "diverged");
  EXPECT_EQ(csv.rows[1].at("status"), "ok");
  for (const std::string& e : trajectory_errors) {
    EXPECT_TRUE(std::isinf(csv.number(0, e))) << e;
    EXPECT_TRUE(std::isfinite(csv.number(1, e))) << e;
  }
}

TEST(CliTrade, MalformedOptionsAreRejectedWithExitCode2) {
  TempDir dir;
  const std::string out = " --no-plot --out " + dir.path().string();
  Result r = trade("scenes/head_on.toml --fixed 1e-4,abc" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--fixed"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml --fixed -1e-4" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--fixed"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml --tol 0" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--tol"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml --fixed 1e-4 --method leapfrog" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--method"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml" + out, dir);  // nothing to measure
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--fixed"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml --fixed 1e-4,3e-5" + out, dir);  // 3e-5 does not divide 1e-4
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("does not divide"), std::string::npos) << r.err;
  // [accuracy] is strict: an unknown metric is rejected with the valid list.
  r = trade("scenes/head_on.toml --fixed 1e-4 --set 'accuracy.metrics=[\"trajectory\", \"bed_hight\"]'" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("unknown metric 'bed_hight'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("trajectory, dissipated_energy, bed_height, kinetic_energy, wall_force"), std::string::npos) << r.err;
  r = trade("scenes/head_on.toml --fixed 1e-4 --set accuracy.metric=trajectory" + out, dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("did you mean 'metrics'"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "trade.csv"));
}

TEST(CliTrade, AReferenceThatDivergesExitsOne) {
  TempDir dir;
  // The reference is a fixed step of 0.8 / 8 = 0.1 s: unstable on the seed slope.
  const Result r = trade("scenes/seed_slope.toml --fixed 0.8 --no-plot --out " + dir.path().string(), dir);
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("reference run"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("diverged"), std::string::npos) << r.err;
}

TEST(CliTrade, AReferenceThatIsNotConvergedIsReported) {
  TempDir dir;
  // head_on's damped contact starts with a jump of the force between steps: Verlet is first order
  // there, so a reference at dt / 8 is not a tenth of the error of the finest setting.
  const Result r = trade("scenes/head_on.toml --fixed 1e-4,5e-5 --no-plot --out " + dir.path().string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("the reference did not converge for position_max"), std::string::npos) << r.err;
  const Csv metrics = read_csv(dir.path() / "trade_metrics.txt");
  ASSERT_FALSE(metrics.rows.empty());
  EXPECT_EQ(metrics.rows[0].at("reference_converged"), "no");
  EXPECT_GT(std::stod(metrics.rows[0].at("reference_error")), 0);
}

TEST(CliTrade, AReferenceFileGivesTheSameErrors) {
  TempDir dir;
  const std::string settings = "scenes/head_on.toml --fixed 1e-4,5e-5 --tol 1e-3 --no-plot --quiet";
  ASSERT_EQ(trade(settings + " --out " + (dir.path() / "a").string(), dir).code, 0);
  const Result r = trade(settings + " --reference " + (dir.path() / "a" / "reference.csv").string() + " --out " +
                             (dir.path() / "b").string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv a = read_csv(dir.path() / "a" / "trade.csv"), b = read_csv(dir.path() / "b" / "trade.csv");
  ASSERT_EQ(a.rows.size(), 3u);
  ASSERT_EQ(b.rows.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k)
    for (const std::string& e : trajectory_errors) EXPECT_EQ(a.rows[k].at(e), b.rows[k].at(e)) << e;
  EXPECT_EQ(read_text(dir.path() / "a" / "trade_metrics.txt"), read_text(dir.path() / "b" / "trade_metrics.txt"));
  // A file that is not a reference is bad input.
  const Result bad = trade(settings + " --reference " + (dir.path() / "a" / "trade_metrics.txt").string() + " --out " +
                               (dir.path() / "c").string(),
                           dir);
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--reference"), std::string::npos) << bad.err;
}

TEST(CliTrade, ObservablesGetANoiseFloorFromPerturbedReferences) {
  TempDir dir;
  // The gap is moved off a whole number of reference steps: head_on's contact begins exactly at a step
  // boundary of the reference (1 mm at 1 m/s), where a 1e-12 m perturbation decides in which step the
  // contact is found, and the noise floor is rightly as large as a step's error.
  const Result r = trade("scenes/head_on.toml --fixed 1e-4 --no-plot --set 'particles[0].position=[-0.050537,0,0]' "
                         "--set 'accuracy.metrics=[\"dissipated_energy\", \"kinetic_energy\"]' --out " +
                             dir.path().string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "trade.csv");
  ASSERT_EQ(csv.rows.size(), 1u);
  for (const char* m : {"dissipated_energy", "kinetic_energy"}) {
    const std::string name(m);
    ASSERT_TRUE(csv.rows[0].count(name + "_error")) << name;
    ASSERT_TRUE(csv.rows[0].count(name + "_noise")) << name;
    // 1e-9 relative perturbations of a 0.25 J collision: noise far below the error of dt = 1e-4.
    EXPECT_LT(csv.number(0, name + "_noise"), 1e-6) << name;
    EXPECT_GT(csv.number(0, name + "_error"), csv.number(0, name + "_noise")) << name;
  }
  const Csv metrics = read_csv(dir.path() / "trade_metrics.txt");
  ASSERT_EQ(metrics.rows.size(), 2u);
  EXPECT_EQ(metrics.rows[0].at("unit"), "J");
}

/// The recommendation recomputed from trade.csv for `metric` against `threshold`: the row index of the
/// cheapest finished row within it (fewest particle-steps, then smaller error, then earlier), restricted
/// to `control` unless empty; -1 when none. NaN threshold: none qualifies.
int cheapest_within(const Csv& trade_csv, const std::string& metric, double threshold,
                    const std::string& control = "") {
  int best = -1;
  for (std::size_t k = 0; k < trade_csv.rows.size(); ++k) {
    const auto& row = trade_csv.rows[k];
    if (row.at("status") != "ok" || (!control.empty() && row.at("control") != control)) continue;
    const double error = trade_csv.number(k, metric + "_error");
    if (!(error <= threshold)) continue;
    const auto b = static_cast<std::size_t>(best);
    if (best < 0 || trade_csv.number(k, "particle_steps") < trade_csv.number(b, "particle_steps") ||
        (trade_csv.number(k, "particle_steps") == trade_csv.number(b, "particle_steps") &&
         error < trade_csv.number(b, metric + "_error")))
      best = static_cast<int>(k);
  }
  return best;
}

/// The finished row of smallest error for `metric`; -1 when none finished.
int most_accurate(const Csv& trade_csv, const std::string& metric) {
  const std::string column = metric + "_error";
  int best = -1;
  for (std::size_t k = 0; k < trade_csv.rows.size(); ++k)
    if (trade_csv.rows[k].at("status") == "ok" &&
        (best < 0 || trade_csv.number(k, column) < trade_csv.number(static_cast<std::size_t>(best), column)))
      best = static_cast<int>(k);
  return best;
}

/// Checks each row of recommendation.csv against the choice recomputed from trade.csv, with the
/// given targets (metric -> value); returns the outcome per metric.
std::map<std::string, std::string> check_recommendation(const fs::path& out,
                                                        const std::map<std::string, double>& targets) {
  const Csv trade_csv = read_csv(out / "trade.csv");
  const Csv rec = read_csv(out / "recommendation.csv");
  std::map<std::string, std::string> outcomes;
  for (std::size_t r = 0; r < rec.rows.size(); ++r) {
    const auto& row = rec.rows[r];
    const std::string metric = row.at("metric");
    SCOPED_TRACE(metric);
    double threshold = NAN;
    std::string criterion = "none";
    if (targets.count(metric)) {
      threshold = targets.at(metric), criterion = "target";
    } else if (trade_csv.rows.at(0).count(metric + "_noise")) {
      threshold = trade_csv.number(0, metric + "_noise"), criterion = "noise";
    }
    EXPECT_EQ(row.at("criterion"), criterion);
    const int chosen = cheapest_within(trade_csv, metric, threshold);
    const int shown = chosen >= 0 ? chosen : criterion == "none" ? -1 : most_accurate(trade_csv, metric);
    EXPECT_EQ(row.at("outcome"), criterion == "none" ? "needs_target" : chosen >= 0 ? "chosen" : "none_within");
    if (shown >= 0) {
      const auto& expected = trade_csv.rows[static_cast<std::size_t>(shown)];
      for (const char* column : {"control", "dt", "tolerance", "particle_steps"})
        EXPECT_EQ(row.at(column), expected.at(column)) << column;
      EXPECT_EQ(row.at("error"), expected.at(metric + "_error"));
    } else {
      EXPECT_EQ(row.at("control"), "");
    }
    const int fixed = cheapest_within(trade_csv, metric, threshold, "fixed");
    const int doubling = cheapest_within(trade_csv, metric, threshold, "doubling");
    EXPECT_EQ(row.at("cheapest_fixed_particle_steps"),
              fixed < 0 ? "" : trade_csv.rows[static_cast<std::size_t>(fixed)].at("particle_steps"));
    EXPECT_EQ(row.at("cheapest_doubling_particle_steps"),
              doubling < 0 ? "" : trade_csv.rows[static_cast<std::size_t>(doubling)].at("particle_steps"));
    outcomes[metric] = row.at("outcome");
  }
  return outcomes;
}

TEST(CliTrade, TheRecommendationIsTheCheapestRowOfTradeCsvWithinTheTargetOrTheNoiseFloor) {
  TempDir dir;
  // head_on measured by observables (the gap as in ObservablesGetANoiseFloorFromPerturbedReferences):
  // kinetic_energy against a target the cheapest row misses, dissipated_energy against one every row
  // meets (so the cheapest, not the most accurate, is chosen), bed_height against its noise floor.
  const Result r = trade("scenes/head_on.toml --fixed 1e-4,5e-5 --tol 1e-2,1e-3,1e-4 --no-plot "
                         "--set 'particles[0].position=[-0.050537,0,0]' "
                         "--set 'accuracy.metrics=[\"dissipated_energy\", \"kinetic_energy\", \"bed_height\"]' "
                         "--target kinetic_energy=1e-4,dissipated_energy=1e-3 --out " + dir.path().string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  ASSERT_TRUE(fs::exists(dir.path() / "recommendation.csv"));
  const std::map<std::string, std::string> outcomes =
      check_recommendation(dir.path(), {{"kinetic_energy", 1e-4}, {"dissipated_energy", 1e-3}});
  ASSERT_EQ(outcomes.size(), 3u);
  for (const auto& [metric, outcome] : outcomes) EXPECT_EQ(outcome, "chosen") << metric;
  // The choices are neither merely the cheapest row nor merely the most accurate one.
  const Csv trade_csv = read_csv(dir.path() / "trade.csv");
  const Csv rec = read_csv(dir.path() / "recommendation.csv");
  ASSERT_EQ(rec.rows.size(), 3u);
  ASSERT_EQ(rec.rows[0].at("metric"), "dissipated_energy");
  ASSERT_EQ(rec.rows[1].at("metric"), "bed_height");
  ASSERT_EQ(rec.rows[2].at("metric"), "kinetic_energy");
  double cheapest = INFINITY;
  for (std::size_t k = 0; k < trade_csv.rows.size(); ++k)
    cheapest = std::min(cheapest, trade_csv.number(k, "particle_steps"));
  EXPECT_GT(rec.number(2, "particle_steps"), cheapest);
  const int best = most_accurate(trade_csv, "dissipated_energy");
  ASSERT_GE(best, 0);
  EXPECT_GT(rec.number(0, "error"), trade_csv.number(static_cast<std::size_t>(best), "dissipated_energy_error"));
  EXPECT_EQ(rec.rows[1].at("criterion"), "noise");
  const std::string setting = rec.rows[2].at("control") == "fixed" ? "fixed dt = " + rec.rows[2].at("dt")
                                                                   : "step doubling tol = " + rec.rows[2].at("tolerance");
  EXPECT_NE(r.out.find("kinetic_energy: " + setting), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(noise floor "), std::string::npos) << r.out;
}

TEST(CliTrade, WithoutANoiseFloorTheRecommendationAsksForATargetAndSkipsDivergedRows) {
  TempDir dir;
  // The seed slope compares trajectories (no noise runs); its 0.1 s step diverges, and a target every
  // finite error meets still does not choose it.
  // A target no row meets names the most accurate row instead.
  const Result r = trade("scenes/seed_slope.toml --fixed 0.1,0.01 --tol 1e-2 --no-plot --target position_max=1e9 "
                         "--target velocity_max=1e-12 --out " + dir.path().string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const std::map<std::string, std::string> outcomes =
      check_recommendation(dir.path(), {{"position_max", 1e9}, {"velocity_max", 1e-12}});
  EXPECT_EQ(outcomes.at("position_max"), "chosen");
  EXPECT_EQ(outcomes.at("velocity_max"), "none_within");
  EXPECT_NE(r.out.find("velocity_max: no setting is within the target of 1e-12 m/s; the most accurate is"),
            std::string::npos) << r.out;
  for (const char* metric : {"position_rms", "velocity_rms"})
    EXPECT_EQ(outcomes.at(metric), "needs_target") << metric;
  const Csv rec = read_csv(dir.path() / "recommendation.csv");
  EXPECT_EQ(rec.rows.at(0).at("dt"), "0.01");
  EXPECT_NE(r.out.find("give --target velocity_rms=VALUE"), std::string::npos) << r.out;
}

TEST(CliTrade, ABadTargetIsRejectedWithExitCode2AndTheValidMetrics) {
  TempDir dir;
  const std::string run = "scenes/head_on.toml --fixed 1e-4 --no-plot --out " + dir.path().string();
  const std::string valid = "position_max, position_rms, velocity_max, velocity_rms";
  Result r = trade(run + " --target bed_height=1e-3", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--target"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("unknown metric 'bed_height'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(valid), std::string::npos) << r.err;
  r = trade(run + " --target position_max=1e-3,velocity_max=fast", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'velocity_max=fast': 'fast' is not a finite number"), std::string::npos) << r.err;
  r = trade(run + " --target position_max=-1e-3", dir);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'-1e-3' is negative"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir.path() / "trade.csv"));  // rejected before any run
}

TEST(CliTrade, CallsThePlotScriptWhenMatplotlibIsThere) {
  if (std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "python3-matplotlib is not installed";
  TempDir dir;
  const Result r = trade("scenes/head_on.toml --fixed 1e-4,5e-5 --tol 1e-3 --quiet --out " + dir.path().string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir.path() / "trade.png")) << r.err;
}

}  // namespace

TEST(CliTrade, AMillIsMeasuredByItsPowerDrawAndCollisionSpectrumUnderBothControls) {
  TempDir dir;
  // The small test mill (120 discs) over its start-up and one revolution, at a fixed step and under
  // step doubling: moving walls make power_draw a default metric, and a mill's collision spectra
  // (booked under either control with Verlet) the collision_spectrum metric.
  const Result r = trade("tests/scenes/mill_small.toml --fixed 2e-4 --tol 1e-2 --until 0.95 --no-plot --out " +
                             dir.path().string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "trade.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  for (const char* column : {"power_draw_error", "collision_spectrum_error", "power_draw_noise", "collision_spectrum_noise"})
    ASSERT_TRUE(csv.rows[0].count(column)) << column << " missing; columns: " << read_text(dir.path() / "trade.csv");
  for (std::size_t row = 0; row < 2; ++row) {
    SCOPED_TRACE(csv.rows[row].at("control"));
    EXPECT_EQ(csv.rows[row].at("status"), "ok");
    const double power = csv.number(row, "power_draw_error"), spectrum = csv.number(row, "collision_spectrum_error");
    EXPECT_TRUE(std::isfinite(power));
    EXPECT_GE(power, 0);
    // 0 for the same spectrum, 1 for disjoint ones.
    EXPECT_TRUE(std::isfinite(spectrum));
    EXPECT_GT(spectrum, 0) << "a different step books different events";
    EXPECT_LE(spectrum, 1);
  }
  EXPECT_EQ(csv.rows[1].at("control"), "doubling");
  // The perturbed references differ in their events too (the charge is chaotic): a noise floor.
  EXPECT_GT(csv.number(0, "collision_spectrum_noise"), 0);
  const std::string metrics = read_text(dir.path() / "trade_metrics.txt");
  EXPECT_NE(metrics.find("power_draw"), std::string::npos);
  EXPECT_NE(metrics.find("collision_spectrum"), std::string::npos);
}

TEST(CliTrade, FromACheckpointEveryRunStartsThereAndTheMetricsCountFromThere) {
  TempDir dir;
  // The small mill warmed through its start-up at its own step, then traded over 0.5 to 0.95 s.
  const std::string mill = "tests/scenes/mill_small.toml";
  const Result warm = dem::test::cli::run_dem_shell("run " + mill + " --quiet --until 0.5 --out " + (dir.path() / "warm").string(),
                                         dir.path(), source_dir);
  ASSERT_EQ(warm.code, 0) << warm.err;
  const fs::path checkpoint = dir.path() / "warm" / "checkpoint_0.5.bin";
  ASSERT_TRUE(fs::exists(checkpoint));
  // The same window by `dem run --from` at the scene's step: what the reference should dissipate.
  const Result window = dem::test::cli::run_dem_shell("run " + mill + " --quiet --until 0.95 --from " + checkpoint.string() +
                                               " --out " + (dir.path() / "window").string(),
                                           dir.path(), source_dir);
  ASSERT_EQ(window.code, 0) << window.err;
  const dem::test::cli::Json summary = dem::test::cli::read_json(dir.path() / "window" / "summary.json");
  const double dissipated = summary["end"]["dissipated_energy"].number - summary["start"]["dissipated_energy"].number;
  ASSERT_GT(dissipated, 0);

  const fs::path out = dir.path() / "trade";
  const Result r = trade(mill + " --from " + checkpoint.string() + " --fixed 2e-4 --tol 1e-2 --until 0.95 --no-plot --out " +
                             out.string(),
                         dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(out / "trade.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  for (std::size_t row = 0; row < 2; ++row) EXPECT_EQ(csv.rows[row].at("status"), "ok");
  const std::string how = read_text(out / "trade_reference.txt");
  EXPECT_NE(how.find("start_time,0.5"), std::string::npos) << how;
  EXPECT_NE(how.find("start_checkpoint," + checkpoint.string()), std::string::npos) << how;
  // The reference's samples: from the checkpoint's time on, its books counted from there.
  const Csv reference = read_csv(out / "reference.csv");
  std::vector<std::map<std::string, std::string>> own;
  for (const auto& row : reference.rows)
    if (row.at("run") == "reference") own.push_back(row);
  ASSERT_GE(own.size(), 2u);
  EXPECT_DOUBLE_EQ(std::stod(own.front().at("time")), 0.5);
  EXPECT_EQ(std::stod(own.front().at("dissipated_energy")), 0);
  EXPECT_EQ(std::stod(own.front().at("power_draw")), 0);
  EXPECT_NEAR(std::stod(own.back().at("time")), 0.95, 0.05);
  EXPECT_NEAR(std::stod(own.back().at("dissipated_energy")), dissipated, 0.2 * dissipated)
      << "the window's dissipation, as dem run --from measured it";

  // Another body, or an end before the checkpoint: bad input.
  EXPECT_EQ(trade(mill + " --from " + checkpoint.string() +
                      " --set contacts[0].normal_stiffness=2e5 --fixed 2e-4 --until 0.95 --no-plot --out " + out.string(),
                  dir)
                .code,
            2);
  const Result early = trade(mill + " --from " + checkpoint.string() + " --fixed 2e-4 --until 0.4 --no-plot --out " +
                                 out.string(),
                             dir);
  EXPECT_EQ(early.code, 2);
  EXPECT_NE(early.err.find("not after the checkpoint's time"), std::string::npos) << early.err;
}

TEST(CliTrade, ACollisionSpectrumNeedsASceneThatBooksOne) {
  TempDir dir;
  // head_on has no [mill]: it books no collision spectra, so asking for the metric is an input error.
  const fs::path scene = dir.path() / "head_on_spectrum.toml";
  std::ofstream(scene) << read_text(source_dir / "scenes/head_on.toml") << "\n[accuracy]\nmetrics = [\"collision_spectrum\"]\n";
  const Result r = trade(scene.string() + " --fixed 1e-4 --no-plot --out " + dir.path().string(), dir);
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("collision_spectrum needs a scene that books collision spectra"), std::string::npos) << r.err;
}
