#pragma once
// summary.json of `dem run`: status, settings, counters, watch, energies, state hash and provenance.
#include "engine/cli/run_loop.h"
#include "engine/json_writer.h"
#include "engine/scene.h"
#include "engine/world.h"

namespace dem::cli {

/// The summary of a run that ended as `end` after `wall_seconds`, having taken `run_particle_steps`
/// (fewer than the counters hold when it resumed a checkpoint); `start_energy` is energy_json of its
/// start (world_records.h). A mill's block is added by the caller.
JsonObject run_summary(const Scene& scene, const World& world, const RunEnd& end, double wall_seconds,
                       std::uint64_t run_particle_steps, const JsonObject& start_energy);

}  // namespace dem::cli
