// The `dem` program: a thin layer over the library. Parses the command line with CLI11 and maps
// failures to exit codes: 0 ok, 1 runtime error, 2 bad input, 3 divergence.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <exception>
#include <filesystem>

#include "engine/cli/commands.h"
#include "engine/cli/plot_script.h"
#include "engine/cli/version.h"
#include "engine/input_error.h"

int main(int argc, char** argv) {
  CLI::App app{"dem: discrete element simulations that tell you how accurate they are"};
  // The second line says where the plotting scripts come from (share/dem of an installation, or the
  // source tree of a build-tree program; plot_script.h).
  const std::filesystem::path scripts = dem::cli::plot_scripts_dir();
  app.set_version_flag("--version", std::string("dem ") + DEM_VERSION + " (git " + DEM_GIT_HASH + ")\nplot scripts: " +
                                        (scripts.empty() ? std::string("none found") : scripts.string()));
  app.require_subcommand(1);

  dem::cli::RunOptions run;
  CLI::App* run_cmd = app.add_subcommand("run", "run a scene and write its outputs");
  run_cmd->add_option("scene", run.scene, "scene file (TOML)")->required();
  run_cmd->add_option("--out", run.out, "output folder (default: out/<scene-name>)");
  run_cmd->add_option("--threads", run.threads, "worker threads (default: the cores of the affinity mask)")
      ->check(CLI::NonNegativeNumber);
  run_cmd->add_option("--until", run.until, "simulated end time [s] (default: the scene's run.until)")
      ->check(CLI::PositiveNumber);
  run_cmd->add_option("--set", run.overrides, "override a scene value: key.path=value (repeatable)");
  run_cmd->add_flag("--quiet", run.quiet, "no progress bar or final line");
  CLI::Option* resume =
      run_cmd->add_option("--resume", run.resume, "continue bit for bit from a checkpoint of this scene")
          ->check(CLI::ExistingFile);
  run_cmd
      ->add_option("--from", run.from,
                   "start from a checkpoint of this scene's particles, materials and walls under this run's integrator "
                   "settings (another control, step or tolerance; the same method): fresh outputs, time goes on from "
                   "the checkpoint's")
      ->check(CLI::ExistingFile)
      ->excludes(resume);
  run_cmd->add_option("--checkpoint-every", run.checkpoint_every,
                      "write checkpoint_<time>.bin every T seconds of simulated time (the newest is kept)")
      ->check(CLI::PositiveNumber);

  std::string check_scene;
  std::vector<std::string> check_overrides;
  CLI::App* check_cmd = app.add_subcommand("check", "validate a scene and print its stability figures");
  check_cmd->add_option("scene", check_scene, "scene file (TOML)")->required();
  check_cmd->add_option("--set", check_overrides, "override a scene value: key.path=value (repeatable)");

  dem::cli::TradeOptions trade;
  CLI::App* trade_cmd = app.add_subcommand(
      "trade", "measure the speed-accuracy trade: fixed steps and doubling tolerances against a reference run");
  trade_cmd->add_option("scene", trade.scene, "scene file (TOML)")->required();
  trade_cmd->add_option("--fixed", trade.fixed, "fixed steps [s], comma-separated (e.g. 1e-3,5e-4)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  trade_cmd->add_option("--tol", trade.tolerances, "step-doubling tolerances, comma-separated (e.g. 1e-2,1e-3)")
      ->delimiter(',')
      ->check(CLI::PositiveNumber);
  trade_cmd->add_option("--method", trade.method, "stepper (default: the scene's)")
      ->check(CLI::IsMember({"verlet", "exact"}));
  trade_cmd->add_option("--reference", trade.reference,
                        "auto (a fixed step 1/8 of the smallest --fixed, checked at 1/16) or a reference.csv of an "
                        "earlier trade (or a trajectories.csv of dem run)");
  trade_cmd->add_option("--out", trade.out, "output folder (default: out/<scene-name>/trade)");
  trade_cmd->add_option("--threads", trade.threads, "worker threads (default: the cores of the affinity mask)")
      ->check(CLI::NonNegativeNumber);
  trade_cmd->add_option("--until", trade.until, "simulated end time [s] (default: the scene's run.until)")
      ->check(CLI::PositiveNumber);
  trade_cmd->add_option("--set", trade.overrides, "override a scene value: key.path=value (repeatable)");
  trade_cmd
      ->add_option("--from", trade.from,
                   "start every run (references too) from this checkpoint of the scene, at its time, as dem run --from "
                   "does; metrics count from there")
      ->check(CLI::ExistingFile);
  trade_cmd->add_option("--target", trade.targets,
                        "recommend the cheapest setting within this absolute error instead of the noise floor: "
                        "METRIC=VALUE, comma-separated or repeated (units in trade_metrics.txt)")
      ->delimiter(',');
  trade_cmd->add_flag("--quiet", trade.quiet, "no progress lines or table");
  trade_cmd->add_flag("!--no-plot", trade.plot, "do not draw trade.png (plot_trade.py)");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    if (*run_cmd) return dem::cli::run_command(run);
    if (*trade_cmd) return dem::cli::trade_command(trade);
    if (*check_cmd) return dem::cli::check_command(check_scene, check_overrides);
  } catch (const dem::InputError& e) {
    std::fprintf(stderr, "dem: error: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dem: runtime error: %s\n", e.what());
    return 1;
  }
  return 1;
}
