// What `dem run` records of a World (world_records.h).
#include "engine/cli/world_records.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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

}  // namespace

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
  for (const ParticleIndex p : s.index_of_id) {  // in id order
    if (p == removed_slot) continue;
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

}  // namespace dem::cli
