// The loop of `dem run` (run_loop.h).
#include "engine/cli/run_loop.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

#include "engine/cli/stability.h"

namespace dem::cli {
namespace {

class ProgressBar {
 public:
  ProgressBar(bool enabled, Real start, Real end) : enabled_(enabled), start_(start), end_(end) {}
  void update(Real t, double wall_seconds) {
    if (!enabled_ || wall_seconds - last_ < 0.2) return;
    last_ = wall_seconds;
    const double fraction = std::clamp((t - start_) / (end_ - start_), 0.0, 1.0);
    const double rate = (t - start_) / std::max(wall_seconds, 1e-9);
    const double eta = rate > 0 ? (end_ - t) / rate : 0;
    const int width = 30, filled = static_cast<int>(fraction * width);
    std::fprintf(stderr, "\r[%.*s%*s] t = %.4g s  %.3g sim-s/s  ETA %.0f s ", filled,
                 "##############################", width - filled, "", t, rate, eta);
    std::fflush(stderr);
  }
  void finish() {
    if (enabled_) std::fprintf(stderr, "\n");
  }

 private:
  bool enabled_;
  Real start_, end_;
  double last_ = -1;
};

}  // namespace

std::filesystem::path checkpoint_path(const std::filesystem::path& out, Real t) {
  char name[64];
  std::snprintf(name, sizeof name, "checkpoint_%.9g.bin", t);
  return out / name;
}

RunEnd run_loop(World& world, const Scene& scene, const RunOptions& options, RunOutputs& outputs,
                DivergenceGuard& guard, const std::filesystem::path& out,
                std::chrono::steady_clock::time_point start_wall) {
  // Periodic checkpoints (--checkpoint-every): the newest replaces the previous one once written.
  OutputSchedule checkpoints(options.checkpoint_every > 0 ? options.checkpoint_every : 0);
  if (checkpoints.enabled()) checkpoints.done_at(world.time());
  ProgressBar progress(!options.quiet && isatty(STDERR_FILENO), world.time(), scene.run.until);
  RunEnd end;
  bool travel_warned = false;
  while (world.time() < scene.run.until) {
    if (world.advance_sync_interval() != StepStatus::ok) {
      const World::Culprit c = world.fastest_particle();
      end.divergence = "non-finite positions or velocities (particle " + std::to_string(c.particle) + ")";
      break;
    }
    const Real t = world.time();
    if (!travel_warned) {
      if (const std::string warning = step_travel_warning(world); !warning.empty()) {
        std::fprintf(stderr, "dem: warning: %s.\n", warning.c_str());
        travel_warned = true;
      }
    }
    if (MillOutputs* mill = outputs.mill()) mill->on_sync(world);
    // Translational only: a particle spinning about its contact normal (nothing resists that spin)
    // does not move and must not keep a settled bed from being written.
    const bool settled = scene.run.stop_kinetic_energy > 0 && t >= scene.run.stop_check_after &&
                         world.energies().kinetic < scene.run.stop_kinetic_energy;
    const bool last = settled || t >= scene.run.until;
    const bool due = outputs.due(t);
    if (due || last) {
      end.divergence = guard.check(world);
      if (!end.divergence.empty()) break;
      outputs.write(world, !due);  // the end writes everything, unless something was due then anyway
      guard.accept(world);
    }
    if (settled) {
      end.stop_reason = "kinetic energy below run.stop_kinetic_energy";
      break;
    }
    if (checkpoints.due(t)) {
      const std::filesystem::path path = checkpoint_path(out, t);
      world.save_checkpoint(path.string(), scene.hashes());
      if (!end.last_checkpoint.empty() && end.last_checkpoint != path) std::filesystem::remove(end.last_checkpoint);
      end.last_checkpoint = path;
      checkpoints.done_at(t);
    }
    progress.update(t, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_wall).count());
  }
  progress.finish();
  return end;
}

}  // namespace dem::cli
