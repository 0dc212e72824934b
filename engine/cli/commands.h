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
  double checkpoint_every = -1;        // [s] simulated time between checkpoints; <= 0: only at the end
};

int run_command(const RunOptions& options);

/// Validates a scene and prints what it contains and the stability figures of each contact class.
int check_command(const std::string& scene, const std::vector<std::string>& overrides);

}  // namespace dem::cli
