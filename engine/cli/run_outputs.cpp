// The output files of `dem run` (run_outputs.h).
#include "engine/cli/run_outputs.h"

#include <string>
#include <vector>

#include "engine/cli/world_records.h"
#include "engine/vtk_snapshots.h"

namespace dem::cli {
namespace {

/// `out`, with the append-only files of an earlier run removed unless this run resumes it.
std::filesystem::path prepared_folder(const std::filesystem::path& out, bool resuming) {
  if (!resuming)
    for (const char* file :
         {"series.csv", "walls.csv", "trajectories.csv", "particles.pvd", "walls.pvd", "contacts.pvd"})
      std::filesystem::remove(out / file);
  return out;
}

std::vector<std::string> wall_names(const World& world) {
  std::vector<std::string> names;
  for (std::size_t w = 0; w < world.walls().count(); ++w) names.push_back(world.walls().config(w).name);
  return names;
}

}  // namespace

RunOutputs::RunOutputs(const Scene& scene, const World& world, const std::filesystem::path& out, bool resuming,
                       bool quiet)
    : out_(prepared_folder(out, resuming)),
      series_(out_ / "series.csv", series_columns()),
      walls_(out_ / "walls.csv", wall_columns(wall_names(world))),
      particles_pvd_(out_ / "particles.pvd"),
      walls_pvd_(out_ / "walls.pvd"),
      vtk_format_(scene.output.vtk_ascii ? VtkFormat::ascii : VtkFormat::binary),
      rows_(scene.output.interval),
      snapshots_(scene.output.snapshot_interval) {
  if (scene.output.trajectories) trajectories_.emplace(out_ / "trajectories.csv", trajectory_columns());
  if (scene.output.contacts) contacts_pvd_.emplace(out_ / "contacts.pvd");
  if (resuming) {
    series_.truncate_after(world.time());
    walls_.truncate_after(world.time());
    if (trajectories_) trajectories_->truncate_after(world.time());
    particles_pvd_.truncate_after(world.time());
    walls_pvd_.truncate_after(world.time());
    if (contacts_pvd_) {
      contacts_pvd_->truncate_after(world.time());
    } else if (std::filesystem::exists(out_ / "contacts.pvd")) {
      // The run that died wrote a contact network this one does not: its index keeps what the
      // checkpoint's time covers, so it never lists snapshots of a future that did not happen.
      PvdIndex(out_ / "contacts.pvd").truncate_after(world.time());
    }
    // A resumed run already wrote what was due at the checkpoint's time.
    rows_.done_at(world.time());
    if (snapshots_.enabled()) snapshots_.done_at(world.time());
  }
  snapshot_count_ = static_cast<std::int64_t>(particles_pvd_.entries().size());
  if (scene.mill) mill_.emplace(*scene.mill, world, out_, resuming, quiet);
}

void RunOutputs::write(const World& world, bool final_row) {
  const Real t = world.time();
  if (rows_.due(t) || final_row) {
    series_.append(series_row(world));
    walls_.append(wall_row(world));
    if (mill_) mill_->on_row(world);
    if (trajectories_) append_trajectories(*trajectories_, world);
    rows_.done_at(t);
  }
  if (snapshots_.due(t) || (snapshots_.enabled() && final_row)) {
    const std::string name = "particles_" + std::to_string(snapshot_count_) + ".vtp";
    write_particles_vtp(out_ / name, particle_snapshot(world), vtk_format_);
    particles_pvd_.add(t, name);
    const std::string wall_name = "walls_" + std::to_string(snapshot_count_) + ".vtp";
    if (world.walls().count() > 0) {
      write_walls_vtp(out_ / wall_name, wall_geometry(world), vtk_format_);
      walls_pvd_.add(t, wall_name);
    }
    if (contacts_pvd_) {
      const std::string contact_name = "contacts_" + std::to_string(snapshot_count_) + ".vtp";
      write_contacts_vtp(out_ / contact_name, contact_snapshot(world), vtk_format_);
      contacts_pvd_->add(t, contact_name);
    }
    ++snapshot_count_;
    snapshots_.done_at(t);
  }
}

}  // namespace dem::cli
