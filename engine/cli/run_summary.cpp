// summary.json of `dem run` (run_summary.h).
#include "engine/cli/run_summary.h"

#include <algorithm>
#include <string>
#include <vector>

#include "engine/cli/version.h"
#include "engine/cli/world_records.h"

namespace dem::cli {
namespace {

JsonObject settings_json(const Scene& scene, const World& world) {
  JsonObject settings;
  settings.add("scene", scene.file)
      .add("scene_name", scene.name)
      .add("dimension", scene.world.model.dimension)
      .add("particles", static_cast<std::uint64_t>(world.state().size()))
      .add("method", scene.world.integrator.method == Method::verlet ? "verlet" : "exact")
      .add("control", scene.world.integrator.control == Control::fixed ? "fixed" : "doubling")
      .add("dt", scene.world.integrator.dt)
      .add("tolerance", scene.world.integrator.tolerance)
      .add("error_per_unit_step", scene.world.integrator.error_per_unit_step)
      .add("particle_levels", scene.world.integrator.particle_levels)
      .add("level_min", scene.world.integrator.level_min)
      .add("level_max", scene.world.integrator.level_max)
      .add("until", scene.run.until)
      .add("output_interval", scene.output.interval)
      .add("skin", world.skin())
      .add("skin_chosen_from_speeds", world.skin_is_chosen())
      .add("candidate_skin", world.candidate_skin());
  return settings;
}

JsonObject counters_json(const Scene& scene, const RunCounters& c) {
  JsonObject counters;
  counters.add("sync_intervals", c.sync_intervals)
      .add("accepted_steps", c.accepted_steps)
      .add("rejected_steps", c.rejected_steps)
      .add("forced_steps", c.forced_steps)
      .add("particle_steps", c.particle_steps)
      .add("force_evaluations", c.force_evaluations)
      .add("pair_rebuilds", c.pair_rebuilds)
      .add("round_redos", c.round_redos)
      .add("member_retries", c.member_retries)
      .add("unresolved_contacts", c.unresolved_contacts)
      .add("richardson_steps", c.richardson_steps);
  // Accepted particle-steps per level ("level": count), levels that were used only.
  JsonObject histogram;
  for (std::size_t k = 0; k < c.level_histogram.size(); ++k)
    if (c.level_histogram[k] > 0)
      histogram.add(std::to_string(static_cast<int>(k) + (scene.world.integrator.control == Control::fixed
                                                              ? 0
                                                              : scene.world.integrator.level_min)),
                    c.level_histogram[k]);
  counters.add("level_histogram", histogram);
  return counters;
}

JsonObject provenance_json(const Scene& scene, const World& world) {
  JsonObject provenance;
  std::vector<double> seeds(scene.seeds.begin(), scene.seeds.end());
  provenance.add("version", DEM_VERSION)
      .add("git_hash", DEM_GIT_HASH)
      .add("compiler", __VERSION__)
      .add("flags", DEM_COMPILE_FLAGS)
      .add("threads", world.thread_count())
      .add("seeds", seeds);
  return provenance;
}

/// What the steps came closest to getting wrong (step_watch.h): the deepest overlap of any step and
/// the longest fixed Verlet step in radii travelled.
JsonObject watch_json(const World& world) {
  JsonObject watch;
  const World::Culprit &deepest = world.deepest_overlap_seen(), &travel = world.longest_step_travel_seen();
  watch.add("deepest_overlap", deepest.value)
      .add("deepest_overlap_particles", std::vector<double>{static_cast<double>(deepest.particle),
                                                             static_cast<double>(deepest.partner)})
      .add("deepest_overlap_time", deepest.time)
      .add("longest_step_travel", travel.value)
      .add("longest_step_travel_particle", static_cast<std::uint64_t>(travel.particle))
      .add("longest_step_travel_time", travel.time);
  return watch;
}

/// The collision spectra's totals per kind and each size class's share of the dissipation
/// (docs/physics.md 7.4): booked events only, contacts still open at the end are not in them.
JsonObject spectra_json(const CollisionSpectra& spectra) {
  JsonObject j;
  j.add("size_classes", spectra.edges());
  JsonObject classes;
  for (int c = 0; c < spectra.class_count(); ++c) {
    JsonObject cls;
    cls.add("radius_min", c == 0 ? 0.0 : spectra.edges()[static_cast<std::size_t>(c - 1)]);
    if (c + 1 < spectra.class_count()) cls.add("radius_max", spectra.edges()[static_cast<std::size_t>(c)]);
    cls.add("dissipation_share", spectra.dissipation_share(c));
    classes.add(spectra.class_name(c), cls);
  }
  j.add("classes", classes);
  JsonObject kinds;
  for (CollisionSpectra::Kind k = 0; k < spectra.kind_count(); ++k) {
    JsonObject kind;
    kind.add("events", spectra.events(k)).add("dissipated", spectra.dissipated(k));
    kinds.add(spectra.kind_name(k), kind);
  }
  j.add("kinds", kinds);
  j.add("dissipated", spectra.dissipated());
  if (spectra.class_count() > 1) j.add("fines_dissipation_share", spectra.dissipation_share(0));
  return j;
}

}  // namespace

JsonObject run_summary(const Scene& scene, const World& world, const RunEnd& end, double wall_seconds,
                       std::uint64_t run_particle_steps, const JsonObject& start_energy) {
  const RunCounters& c = world.counters();
  JsonObject summary;
  summary.add("status", end.divergence.empty() ? "ok" : "diverged")
      .add("stop_reason", end.divergence.empty() ? end.stop_reason : end.divergence)
      .add("time", world.time())
      .add("settings", settings_json(scene, world))
      .add("counters", counters_json(scene, c))
      .add("watch", watch_json(world))
      .add("wall_time", wall_seconds)
      // This invocation's steps (a resumed run's counters go on from its checkpoint's).
      .add("run_particle_steps", run_particle_steps)
      .add("particle_steps_per_second", static_cast<double>(run_particle_steps) / std::max(wall_seconds, 1e-9))
      .add("start", start_energy)
      .add("end", energy_json(world))
      .add("state_hash", hex(world.state_hash()))
      .add("provenance", provenance_json(scene, world));
  if (const CollisionSpectra* spectra = world.collision_spectra()) summary.add("collision_spectra", spectra_json(*spectra));
  return summary;
}

}  // namespace dem::cli
