// `dem run`: builds the world from a scene, advances it sync interval by sync interval and writes the
// outputs of docs/design.md, Outputs (series.csv, walls.csv, summary.json, VTK snapshots with a .pvd index).
// Outputs never shorten a step: a row is written at the first sync time at or after each multiple
// of output.interval, and the run ends at the first sync time at or after `until`.
#include <algorithm>
#include "engine/cli/commands.h"
#include "engine/cli/energy_audit.h"
#include "engine/cli/stability.h"
#include "engine/cli/mill_outputs.h"
#include "engine/cli/version.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>

#include "engine/input_error.h"
#include "engine/atomic_file.h"
#include "engine/csv_writer.h"
#include "engine/json_writer.h"
#include "engine/vtk_snapshots.h"
#include "engine/vtk_writer.h"
#include "engine/particle_csv.h"
#include "engine/world.h"

namespace dem::cli {
namespace {

int finest_level(const World& world) {
  const auto& level = world.state().level;
  return level.empty() ? 0 : *std::min_element(level.begin(), level.end());
}

int coarsest_level(const World& world) {
  const auto& level = world.state().level;
  return level.empty() ? 0 : *std::max_element(level.begin(), level.end());
}

std::vector<double> series_row(const World& world) {
  const Energies e = world.energies();
  const Vec3 p = world.linear_momentum();
  const RunCounters& c = world.counters();
  return {world.time(),
          e.kinetic,
          e.rotational,
          e.potential,
          e.elastic,
          world.dissipated_energy(),
          p.x(),
          p.y(),
          p.z(),
          static_cast<double>(world.pair_contacts().size()),
          static_cast<double>(world.wall_contacts().size()),
          static_cast<double>(c.sync_intervals),
          static_cast<double>(c.accepted_steps),
          static_cast<double>(c.rejected_steps),
          static_cast<double>(c.forced_steps),
          static_cast<double>(c.particle_steps),
          static_cast<double>(c.force_evaluations),
          static_cast<double>(c.pair_rebuilds),
          static_cast<double>(c.round_redos),
          static_cast<double>(finest_level(world)),
          static_cast<double>(coarsest_level(world))};
}

void append_trajectories(SeriesWriter& out, const World& world) {
  const State& s = world.state();
  for (std::size_t p = 0; p < s.size(); ++p) {  // slots are in id order
    const Vec3 &x = s.position[p], &v = s.velocity[p], &w = s.angular_velocity[p];
    out.append({world.time(), static_cast<double>(s.id[p]), x.x(), x.y(), x.z(), v.x(), v.y(), v.z(), w.x(), w.y(), w.z()});
  }
}

std::vector<double> wall_row(const World& world) {
  std::vector<double> row{world.time()};
  for (const WallLoad& load : world.wall_loads()) {
    for (int k = 0; k < 3; ++k) row.push_back(load.force[k]);
    for (int k = 0; k < 3; ++k) row.push_back(load.torque[k]);
  }
  return row;
}

/// Display geometry of the walls at the world's current time; infinite things get a finite extent.
WallGeometry wall_geometry(const World& world) {
  WallGeometry all;
  const State& s = world.state();
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (std::size_t p = 0; p < s.size(); ++p) {
    lo = lo.cwiseMin(s.position[p]);
    hi = hi.cwiseMax(s.position[p]);
  }
  const Real extent = s.size() > 0 ? std::max((hi - lo).norm(), Real{1e-3}) : 1;
  for (std::size_t w = 0; w < world.walls().count(); ++w) {
    const WallConfig& c = world.walls().config(w);
    const Eigen::Matrix3d& rotation = world.walls().rotation(w);
    const auto wall = static_cast<std::uint32_t>(w);
    switch (c.kind) {
      case WallKind::plane:
        append_wall_geometry(all, plane_geometry(world.walls().point(w), rotation * c.normal, extent, wall));
        break;
      case WallKind::box:
        append_wall_geometry(all, box_geometry(world.walls().point(w), c.half_extents, rotation, wall));
        break;
      case WallKind::cylinder: {
        const Real length = std::isfinite(c.length) ? c.length : extent;
        append_wall_geometry(all, cylinder_geometry(world.walls().point(w), rotation * c.axis, c.radius, length, 64, wall));
        break;
      }
      case WallKind::prism: {
        std::vector<Eigen::Vector3d> corners;
        for (const Vec3& corner : c.profile) corners.push_back(world.walls().point(w) + rotation * (corner - c.point));
        const Real length = std::isfinite(c.length) ? c.length : extent;
        append_wall_geometry(all, prism_geometry(corners, rotation * c.axis, length, wall));
        break;
      }
      case WallKind::mesh: {  // the triangles themselves, moved to the wall's current pose
        const TriangleMesh& mesh = *world.walls().mesh(w);
        WallGeometry part;
        for (const Vec3& v : mesh.vertices()) part.points.push_back(world.walls().point(w) + rotation * v);
        part.triangles = mesh.triangles();
        part.wall_index.assign(mesh.triangle_count(), wall);
        append_wall_geometry(all, part);
        break;
      }
    }
  }
  return all;
}

JsonObject energy_json(const World& world) {
  const Energies e = world.energies();
  const Vec3 p = world.linear_momentum();
  JsonObject j;
  j.add("kinetic_energy", e.kinetic)
      .add("rotational_energy", e.rotational)
      .add("potential_energy", e.potential)
      .add("elastic_energy", e.elastic)
      .add("dissipated_energy", world.dissipated_energy())
      .add("wall_work", world.wall_work())
      .add("momentum", std::vector<double>{p.x(), p.y(), p.z()});
  return j;
}

std::string hex(std::uint64_t v) {
  char text[20];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(v));
  return text;
}

/// When an output is due: at the first sync time at or after each multiple k * interval. Sync times
/// are products of integers and dt, so k * interval itself may round a hair above the sync time
/// meant to hit it (0.1 * 3 > 0.3): a tolerance of 1e-9 interval absorbs that.
class OutputSchedule {
 public:
  explicit OutputSchedule(Real interval) : interval_(interval) {}
  bool enabled() const { return interval_ > 0; }
  bool due(Real t) const { return enabled() && t >= (static_cast<Real>(next_) - tolerance) * interval_; }
  /// Marks the output at time t done: the next is the first multiple after t.
  void done_at(Real t) { next_ = std::max(next_ + 1, static_cast<std::int64_t>(std::floor(t / interval_ + tolerance)) + 1); }

 private:
  static constexpr Real tolerance = 1e-9;
  Real interval_;
  std::int64_t next_ = 0;
};

/// The divergence guard: audits a state before results are written and keeps the last state that
/// passed (in memory, as checkpoint bytes) for when a later one does not.
class DivergenceGuard {
 public:
  DivergenceGuard(const World& world, std::uint64_t physics_hash)
      : physics_hash_(physics_hash), audit_(world), checkpoint_(world.checkpoint_bytes(physics_hash)) {}

  /// Empty if the state is sound, else why the run must stop.
  std::string check(const World& world) const { return audit_.check(world); }
  /// The state passed the audit: it is the last good one, and the next window starts here.
  void accept(const World& world) {
    audit_.accept(world);
    checkpoint_ = world.checkpoint_bytes(physics_hash_);
  }

  Real last_good_time() const { return audit_.last_good_time(); }
  /// The bytes of a checkpoint of the last good state.
  const std::string& last_good_checkpoint() const { return checkpoint_; }

 private:
  std::uint64_t physics_hash_;
  EnergyAudit audit_;
  std::string checkpoint_;
};

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

int run_command(const RunOptions& options) {
  Scene scene = load_scene(options.scene, options.overrides);
  // A step beyond Verlet's stability limit is allowed (the energy audit stops the run if it
  // diverges), but said at once.
  for (const std::string& warning : stability_warnings(scene.world, contact_stability(scene.world)))
    std::fprintf(stderr, "dem: warning: %s\n", warning.c_str());
  if (options.threads >= 0) scene.world.threads = options.threads;
  if (options.until > 0) scene.run.until = options.until;
  const std::filesystem::path out = options.out.empty() ? std::filesystem::path("out") / scene.name : std::filesystem::path(options.out);
  std::filesystem::create_directories(out);

  const auto start_wall = std::chrono::steady_clock::now();
  World world(scene.world);
  if (!options.resume.empty()) {
    try {
      world.load_checkpoint(options.resume, scene.physics_hash);
    } catch (const std::runtime_error& e) {
      throw InputError(options.resume, 0, 0, "--resume", e.what());
    }
  }
  const JsonObject start_energy = energy_json(world);

  std::vector<std::string> wall_names;
  for (std::size_t w = 0; w < world.walls().count(); ++w) wall_names.push_back(world.walls().config(w).name);
  // A new run starts its append-only files afresh; a resumed one keeps what was written up to the
  // checkpoint's time and drops anything later (written after the checkpoint by the run that died).
  const bool resuming = !options.resume.empty();
  if (!resuming)
    for (const char* file :
         {"series.csv", "walls.csv", "trajectories.csv", "particles.pvd", "walls.pvd", "contacts.pvd"})
      std::filesystem::remove(out / file);
  SeriesWriter series(out / "series.csv", series_columns());
  std::optional<SeriesWriter> trajectories;
  if (scene.output.trajectories) trajectories.emplace(out / "trajectories.csv", trajectory_columns());
  SeriesWriter walls(out / "walls.csv", wall_columns(wall_names));
  PvdIndex particles_pvd(out / "particles.pvd");
  PvdIndex walls_pvd(out / "walls.pvd");
  std::optional<PvdIndex> contacts_pvd;
  if (scene.output.contacts) contacts_pvd.emplace(out / "contacts.pvd");
  const VtkFormat vtk_format = scene.output.vtk_ascii ? VtkFormat::ascii : VtkFormat::binary;
  if (resuming) {
    series.truncate_after(world.time());
    walls.truncate_after(world.time());
    if (trajectories) trajectories->truncate_after(world.time());
    particles_pvd.truncate_after(world.time());
    walls_pvd.truncate_after(world.time());
    if (contacts_pvd) contacts_pvd->truncate_after(world.time());
  }

  const Real interval = scene.output.interval;
  const Real snapshot_interval = scene.output.snapshot_interval;
  // Output schedules; a resumed run already wrote what was due at the checkpoint's time.
  OutputSchedule rows(interval), snapshots(snapshot_interval);
  std::int64_t snapshot_count = static_cast<std::int64_t>(particles_pvd.entries().size());
  if (resuming) {
    rows.done_at(world.time());
    if (snapshots.enabled()) snapshots.done_at(world.time());
  }
  std::optional<MillOutputs> mill;
  if (scene.mill) mill.emplace(*scene.mill, world, out, resuming, options.quiet);
  // Writes what is due at the current sync time (everything when `final_row`).
  auto write_outputs = [&](bool final_row) {
    const Real t = world.time();
    if (rows.due(t) || final_row) {
      series.append(series_row(world));
      walls.append(wall_row(world));
      if (mill) mill->on_row(world);
      if (trajectories) append_trajectories(*trajectories, world);
      rows.done_at(t);
    }
    if (snapshots.due(t) || (snapshots.enabled() && final_row)) {
      const std::string name = "particles_" + std::to_string(snapshot_count) + ".vtp";
      write_particles_vtp(out / name, particle_snapshot(world), vtk_format);
      particles_pvd.add(t, name);
      const std::string wall_name = "walls_" + std::to_string(snapshot_count) + ".vtp";
      if (world.walls().count() > 0) {
        write_walls_vtp(out / wall_name, wall_geometry(world), vtk_format);
        walls_pvd.add(t, wall_name);
      }
      if (contacts_pvd) {
        const std::string contact_name = "contacts_" + std::to_string(snapshot_count) + ".vtp";
        write_contacts_vtp(out / contact_name, contact_snapshot(world), vtk_format);
        contacts_pvd->add(t, contact_name);
      }
      ++snapshot_count;
      snapshots.done_at(t);
    }
  };
  if (!resuming) write_outputs(false);

  // Periodic checkpoints (--checkpoint-every): the newest replaces the previous one once written.
  OutputSchedule checkpoints(options.checkpoint_every > 0 ? options.checkpoint_every : 0);
  if (checkpoints.enabled()) checkpoints.done_at(world.time());
  std::filesystem::path last_checkpoint;
  auto checkpoint_name = [&](Real t) {
    char name[64];
    std::snprintf(name, sizeof name, "checkpoint_%.9g.bin", t);
    return out / name;
  };

  ProgressBar progress(!options.quiet && isatty(STDERR_FILENO), world.time(), scene.run.until);
  // Every sync time that writes results (a row or snapshot due, the end, the settle stop) is audited
  // first, so no path writes a diverged state.
  DivergenceGuard guard(world, scene.physics_hash);
  std::string divergence;  // why the run diverged; empty while it has not
  std::string stop_reason = "end time reached";
  bool travel_warned = false;
  while (world.time() < scene.run.until) {
    if (world.advance_sync_interval() != StepStatus::ok) {
      const World::Culprit c = world.fastest_particle();
      divergence = "non-finite positions or velocities (particle " + std::to_string(c.particle) + ")";
      break;
    }
    const Real t = world.time();
    if (!travel_warned) {
      if (const std::string warning = step_travel_warning(world); !warning.empty()) {
        std::fprintf(stderr, "dem: warning: %s.\n", warning.c_str());
        travel_warned = true;
      }
    }
    if (mill) mill->on_sync(world);
    // Translational only: a particle spinning about its contact normal (nothing resists that spin)
    // does not move and must not keep a settled bed from being written.
    const bool settled = scene.run.stop_kinetic_energy > 0 && t >= scene.run.stop_check_after &&
                         world.energies().kinetic < scene.run.stop_kinetic_energy;
    const bool last = settled || t >= scene.run.until;
    const bool due = rows.due(t) || snapshots.due(t);
    if (due || last) {
      divergence = guard.check(world);
      if (!divergence.empty()) break;
      write_outputs(!due);  // the end writes everything, unless something was due then anyway
      guard.accept(world);
    }
    if (settled) {
      stop_reason = "kinetic energy below run.stop_kinetic_energy";
      break;
    }
    if (checkpoints.due(t)) {
      const std::filesystem::path path = checkpoint_name(t);
      world.save_checkpoint(path.string(), scene.physics_hash);
      if (!last_checkpoint.empty() && last_checkpoint != path) std::filesystem::remove(last_checkpoint);
      last_checkpoint = path;
      checkpoints.done_at(t);
    }
    progress.update(t, std::chrono::duration<double>(std::chrono::steady_clock::now() - start_wall).count());
  }
  progress.finish();
  const double wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_wall).count();

  // Everything a run restarted from the file needs to go on as this one would: ids, the mass or
  // density each particle was given, material and state (engine/particle_csv.h).
  if (!scene.output.settled_file.empty() && divergence.empty())
    write_particle_csv((out / scene.output.settled_file).string(), world.particles());

  const RunCounters& c = world.counters();
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
      .add("level_min", scene.world.integrator.level_min)
      .add("level_max", scene.world.integrator.level_max)
      .add("until", scene.run.until)
      .add("output_interval", interval)
      .add("skin", world.skin())
      .add("skin_chosen_from_speeds", world.skin_is_chosen())
      .add("candidate_skin", world.candidate_skin());
  JsonObject counters;
  counters.add("sync_intervals", c.sync_intervals)
      .add("accepted_steps", c.accepted_steps)
      .add("rejected_steps", c.rejected_steps)
      .add("forced_steps", c.forced_steps)
      .add("particle_steps", c.particle_steps)
      .add("force_evaluations", c.force_evaluations)
      .add("pair_rebuilds", c.pair_rebuilds)
      .add("round_redos", c.round_redos)
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
  JsonObject provenance;
  std::vector<double> seeds(scene.seeds.begin(), scene.seeds.end());
  provenance.add("version", DEM_VERSION)
      .add("git_hash", DEM_GIT_HASH)
      .add("compiler", __VERSION__)
      .add("flags", DEM_COMPILE_FLAGS)
      .add("threads", world.thread_count())
      .add("seeds", seeds);
  // What the steps came closest to getting wrong (step_watch.h): the deepest overlap of any step and
  // the longest fixed Verlet step in radii travelled.
  JsonObject watch;
  const World::Culprit &deepest = world.deepest_overlap_seen(), &travel = world.longest_step_travel_seen();
  watch.add("deepest_overlap", deepest.value)
      .add("deepest_overlap_particles", std::vector<double>{static_cast<double>(deepest.particle),
                                                             static_cast<double>(deepest.partner)})
      .add("deepest_overlap_time", deepest.time)
      .add("longest_step_travel", travel.value)
      .add("longest_step_travel_particle", static_cast<std::uint64_t>(travel.particle))
      .add("longest_step_travel_time", travel.time);
  JsonObject summary;
  summary.add("status", divergence.empty() ? "ok" : "diverged")
      .add("stop_reason", divergence.empty() ? stop_reason : divergence)
      .add("time", world.time())
      .add("settings", settings)
      .add("counters", counters)
      .add("watch", watch)
      .add("wall_time", wall_seconds)
      .add("particle_steps_per_second", static_cast<double>(c.particle_steps) / std::max(wall_seconds, 1e-9))
      .add("start", start_energy)
      .add("end", energy_json(world))
      .add("state_hash", hex(world.state_hash()))
      .add("provenance", provenance);
  if (mill) {
    mill->write_spectra(world);
    summary.add("mill", mill->summary(world));
    if (const auto p = mill->mean_power_draw()) summary.add("mean_power_draw", *p);
  }
  write_file_atomically(out / "summary.json", summary.dump(2) + "\n");
  if (divergence.empty()) {
    const std::filesystem::path path = checkpoint_name(world.time());
    world.save_checkpoint(path.string(), scene.physics_hash);
    if (!last_checkpoint.empty() && last_checkpoint != path) std::filesystem::remove(last_checkpoint);
  }

  if (!divergence.empty()) {
    // The last good state's checkpoint replaces the periodic one: written after the last good audit,
    // that one holds a state no audit passed; written before, it is older.
    const std::filesystem::path good = checkpoint_name(guard.last_good_time());
    if (!last_checkpoint.empty() && last_checkpoint != good) std::filesystem::remove(last_checkpoint);
    write_file_atomically(good, guard.last_good_checkpoint());
    std::fprintf(stderr,
                 "dem: the run diverged at t = %.9g s: %s. If the step is beyond the stability limit, reduce integrator.dt "
                 "(`dem check` prints the stability limit of each contact) or use integrator.method = \"exact\". "
                 "The last good state (t = %.9g s) is in %s.\n",
                 world.time(), divergence.c_str(), guard.last_good_time(), good.string().c_str());
    return 3;
  }
  if (!options.quiet)
    std::printf("%s: t = %.6g s, %llu particle-steps in %.3g s (%.3g particle-steps/s), state hash %s, outputs in %s\n",
                scene.name.c_str(), world.time(), static_cast<unsigned long long>(c.particle_steps), wall_seconds,
                static_cast<double>(c.particle_steps) / std::max(wall_seconds, 1e-9), hex(world.state_hash()).c_str(),
                out.string().c_str());
  return 0;
}

}  // namespace dem::cli
