#pragma once
// The loop of `dem run`: advances the World sync interval by sync interval to the end time, a settled
// bed or a divergence, writing the outputs that are due and periodic checkpoints.
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <string>

#include "engine/cli/commands.h"
#include "engine/cli/energy_audit.h"
#include "engine/cli/run_outputs.h"
#include "engine/world.h"

namespace dem::cli {

/// The divergence guard: audits a state before results are written and keeps the last state that
/// passed (in memory, as checkpoint bytes) for when a later one does not.
class DivergenceGuard {
 public:
  DivergenceGuard(const World& world, const SceneHashes& hashes)
      : hashes_(hashes), audit_(world), checkpoint_(world.checkpoint_bytes(hashes)) {}

  /// Empty if the state is sound, else why the run must stop.
  std::string check(const World& world) const { return audit_.check(world); }
  /// The state passed the audit: it is the last good one, and the next window starts here.
  void accept(const World& world) {
    audit_.accept(world);
    checkpoint_ = world.checkpoint_bytes(hashes_);
  }

  Real last_good_time() const { return audit_.last_good_time(); }
  /// The bytes of a checkpoint of the last good state.
  const std::string& last_good_checkpoint() const { return checkpoint_; }

 private:
  SceneHashes hashes_;
  EnergyAudit audit_;
  std::string checkpoint_;
};

/// How the loop ended.
struct RunEnd {
  std::string divergence;                      // why the run diverged; empty when it did not
  std::string stop_reason = "end time reached";
  std::filesystem::path last_checkpoint;       // the periodic checkpoint on disk, if any
};

/// The file of the checkpoint at time t in folder `out`.
std::filesystem::path checkpoint_path(const std::filesystem::path& out, Real t);

/// Runs `world` to scene.run.until (options.checkpoint_every: the periodic checkpoints; progress on
/// a terminal unless options.quiet). Every sync time that writes results (a row or snapshot due, the
/// end, the settle stop) is audited by `guard` first, so no path writes a diverged state.
RunEnd run_loop(World& world, const Scene& scene, const RunOptions& options, RunOutputs& outputs,
                DivergenceGuard& guard, const std::filesystem::path& out,
                std::chrono::steady_clock::time_point start_wall);

}  // namespace dem::cli
