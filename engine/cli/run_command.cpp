// `dem run`: builds the world from a scene, advances it sync interval by sync interval and writes the
// outputs of docs/design.md, Outputs (series.csv, walls.csv, summary.json, VTK snapshots with a .pvd index).
// Outputs never shorten a step: a row is written at the first sync time at or after each multiple
// of output.interval, and the run ends at the first sync time at or after `until`.
// The driver: the loop is run_loop.h, the files written as it goes run_outputs.h, the summary
// run_summary.h.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "engine/cli/commands.h"
#include "engine/cli/run_loop.h"
#include "engine/cli/run_outputs.h"
#include "engine/cli/run_summary.h"
#include "engine/cli/stability.h"
#include "engine/cli/world_records.h"
#include "engine/input_error.h"
#include "engine/atomic_file.h"
#include "engine/csv_writer.h"
#include "engine/json_writer.h"
#include "engine/particle_csv.h"
#include "engine/world.h"

namespace dem::cli {
namespace {

/// The scene of a run with the command line's settings applied; stability warnings printed.
Scene run_scene(const RunOptions& options) {
  Scene scene = load_scene(options.scene, options.overrides);
  // A step beyond Verlet's stability limit is allowed (the energy audit stops the run if it
  // diverges), but said at once.
  for (const std::string& warning : stability_warnings(scene.world, contact_stability(scene.world)))
    std::fprintf(stderr, "dem: warning: %s\n", warning.c_str());
  if (options.threads >= 0) scene.world.threads = options.threads;
  if (options.until > 0) scene.run.until = options.until;
  return scene;
}

/// The checkpoints left at the end: the final state's after a sound run; after a divergence, the
/// last good state's, which replaces the periodic one (written after the last good audit, that one
/// holds a state no audit passed; written before, it is older). Returns the last good state's file.
std::filesystem::path leave_checkpoints(const World& world, const Scene& scene, const RunEnd& end,
                                        const DivergenceGuard& guard, const std::filesystem::path& out) {
  if (end.divergence.empty()) {
    const std::filesystem::path path = checkpoint_path(out, world.time());
    world.save_checkpoint(path.string(), scene.hashes());
    if (!end.last_checkpoint.empty() && end.last_checkpoint != path) std::filesystem::remove(end.last_checkpoint);
    return path;
  }
  const std::filesystem::path good = checkpoint_path(out, guard.last_good_time());
  if (!end.last_checkpoint.empty() && end.last_checkpoint != good) std::filesystem::remove(end.last_checkpoint);
  write_file_atomically(good, guard.last_good_checkpoint());
  return good;
}

}  // namespace

int run_command(const RunOptions& options) {
  Scene scene = run_scene(options);
  const std::filesystem::path out = options.out.empty() ? std::filesystem::path("out") / scene.name : std::filesystem::path(options.out);
  std::filesystem::create_directories(out);

  const auto start_wall = std::chrono::steady_clock::now();
  World world(scene.world);
  const bool resuming = !options.resume.empty();
  try {
    if (resuming) world.load_checkpoint(options.resume, scene.hashes());
    if (!options.from.empty()) world.start_from_checkpoint(options.from, scene.hashes());
  } catch (const std::runtime_error& e) {
    throw InputError(resuming ? options.resume : options.from, 0, 0, resuming ? "--resume" : "--from", e.what());
  }
  const JsonObject start_energy = energy_json(world);
  const std::uint64_t steps_before = world.counters().particle_steps;  // a checkpoint's, when resuming
  RunOutputs outputs(scene, world, out, resuming, options.quiet);
  if (!resuming) outputs.write(world, false);
  DivergenceGuard guard(world, scene.hashes());
  const RunEnd end = run_loop(world, scene, options, outputs, guard, out, start_wall);
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_wall).count();

  // Everything a run restarted from the file needs to go on as this one would: ids, the mass or
  // density each particle was given, material and state (engine/particle_csv.h).
  if (!scene.output.settled_file.empty() && end.divergence.empty())
    write_particle_csv((out / scene.output.settled_file).string(), world.particles());
  const std::uint64_t run_steps = world.counters().particle_steps - steps_before;
  JsonObject summary = run_summary(scene, world, end, wall_seconds, run_steps, start_energy);
  if (MillOutputs* mill = outputs.mill()) {
    summary.add("mill", mill->summary(world));
    if (const auto p = mill->mean_power_draw()) summary.add("mean_power_draw", *p);
  }
  write_file_atomically(out / "summary.json", summary.dump(2) + "\n");
  // After summary.json: the spectra's plot names the size classes from it.
  if (MillOutputs* mill = outputs.mill()) mill->write_spectra(world);
  const std::filesystem::path checkpoint = leave_checkpoints(world, scene, end, guard, out);

  if (!end.divergence.empty()) {
    std::fprintf(stderr,
                 "dem: the run diverged at t = %.9g s: %s. If the step is beyond the stability limit, reduce integrator.dt "
                 "(`dem check` prints the stability limit of each contact) or use integrator.method = \"exact\". "
                 "The last good state (t = %.9g s) is in %s.\n",
                 world.time(), end.divergence.c_str(), guard.last_good_time(), checkpoint.string().c_str());
    return 3;
  }
  if (!options.quiet)
    std::printf("%s: t = %.6g s, %llu particle-steps in %.3g s (%.3g particle-steps/s), state hash %s, outputs in %s\n",
                scene.name.c_str(), world.time(), static_cast<unsigned long long>(run_steps), wall_seconds,
                static_cast<double>(run_steps) / std::max(wall_seconds, 1e-9), hex(world.state_hash()).c_str(),
                out.string().c_str());
  return 0;
}

}  // namespace dem::cli
