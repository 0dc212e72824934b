#pragma once
// The `dem` subcommands; main.cpp parses the command line (CLI11) and calls these.
// Each returns the process exit code: 0 ok, 1 runtime error, 2 bad input, 3 divergence.
#include <string>
#include <vector>

#include "engine/scene_loader.h"

namespace dem::cli {

struct RunOptions {
  std::string scene;
  std::string out;                     // default: out/<scene-name>
  int threads = -1;                    // -1: the scene's setting (default: every core)
  double until = -1;                   // -1: the scene's run.until [s]
  std::vector<std::string> overrides;  // --set key.path=value
  bool quiet = false;
  std::string resume;                  // checkpoint to continue from
  std::string from;                    // checkpoint to start from under this run's integrator settings
  double checkpoint_every = -1;        // [s] simulated time between checkpoints; <= 0: only at the end
};

int run_command(const RunOptions& options);

/// `dem trade`: the speed-accuracy trade of a scene against a reference run (trade_command.cpp).
struct TradeOptions {
  std::string scene;
  std::vector<double> fixed;           // --fixed: fixed steps [s]
  std::vector<double> tolerances;      // --tol: step-doubling tolerances
  std::string method;                  // --method: verlet or exact; empty: the scene's
  std::string reference = "auto";      // auto, or a reference.csv / trajectories.csv to load
  std::string out;                     // default: out/<scene-name>/trade
  int threads = -1;                    // -1: the scene's setting
  double until = -1;                   // -1: the scene's run.until [s]
  std::vector<std::string> overrides;  // --set key.path=value
  std::vector<std::string> targets;    // --target METRIC=VALUE: an absolute error to recommend against
  std::string from;                    // --from: a checkpoint every run starts from; empty: the scene's start
  bool quiet = false;
  bool plot = true;                    // draw trade.png with plot_trade.py
};

int trade_command(const TradeOptions& options);

/// Validates a scene and prints what it contains and the stability figures of each contact class.
int check_command(const std::string& scene, const std::vector<std::string>& overrides);

}  // namespace dem::cli
