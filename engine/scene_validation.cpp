// Cross-section checks of a scene (scene_validation.h).
#include "engine/scene_validation.h"

#include <algorithm>
#include <limits>
#include <map>
#include <optional>
#include <sstream>

#include "broadphase/grid.h"
#include "engine/input_error.h"
#include "engine/materials.h"
#include "engine/toml_reader.h"
#include "engine/walls.h"

namespace dem {
namespace loader {

/// Every pair of materials that can meet needs contact parameters, from an entry naming the pair or
/// the default entry: two particle materials (a material with itself included), or a particle
/// material and a wall material. Walls never touch walls, so a pair of wall materials (or of
/// materials nothing uses) needs no entry. Called once particles and walls are read.
void check_contact_pairs(TableReader& top, const Scene& scene) {
  const auto& contacts = scene.world.contacts;
  const auto is_default = [](const ContactConfig& c) { return c.material_a.empty(); };
  if (std::any_of(contacts.begin(), contacts.end(), is_default)) return;
  const auto& materials = scene.world.materials;
  std::map<std::string, std::size_t> index;
  for (std::size_t i = 0; i < materials.size(); ++i) index[materials[i].name] = i;
  std::vector<bool> particle(materials.size()), wall(materials.size());  // used by particles, by walls
  for (const ParticleConfig& p : scene.world.particles) particle[index.at(p.material)] = true;
  for (const WallConfig& w : scene.world.walls) wall[index.at(w.material)] = true;
  for (std::size_t i = 0; i < materials.size(); ++i)
    for (std::size_t j = i; j < materials.size(); ++j) {
      const std::string &a = materials[i].name, &b = materials[j].name;
      std::string meet;
      if (particle[i] && particle[j])
        meet = i == j ? "particles of '" + a + "' touch each other"
                      : "particles of '" + a + "' touch particles of '" + b + "'";
      else if (particle[i] && wall[j])
        meet = "particles of '" + a + "' touch walls of '" + b + "'";
      else if (particle[j] && wall[i])
        meet = "particles of '" + b + "' touch walls of '" + a + "'";
      if (meet.empty()) continue;
      const bool covered = std::any_of(contacts.begin(), contacts.end(), [&](const ContactConfig& c) {
        return (c.material_a == a && c.material_b == b) || (c.material_a == b && c.material_b == a);
      });
      if (!covered)
        top.fail("contacts", "no contact parameters for materials '" + a + "' and '" + b + "' (" + meet +
                                 "): add a [[contacts]] entry with materials = [\"" + a + "\", \"" + b +
                                 "\"] and at least normal_stiffness, or one without `materials` as the default");
    }
}

/// When a particle file gives ids: gives every particle its id, the one its file gave, else (in
/// scene order) the next after the largest id given; orders particles (and their sources) by id, as
/// a World needs them (slots follow ids); rejects an id given twice. A scene without ids keeps its
/// order and leaves ids to the World, which numbers particles 0, 1, 2, ... in that order.
void assign_particle_ids(Scene& scene, std::vector<ParticleSource> id_cells) {
  std::vector<ParticleConfig>& particles = scene.world.particles;
  const std::size_t n = particles.size();
  id_cells.resize(n);
  std::optional<std::size_t> largest;  // the particle with the largest given id
  for (std::size_t i = 0; i < n; ++i)
    if (particles[i].id && (!largest || *particles[i].id > *particles[*largest].id)) largest = i;
  if (!largest) return;
  const auto fail_at = [&](std::size_t i, const std::string& message) {
    const ParticleSource& c = id_cells[i];
    throw InputError(c.file, c.line, c.column, c.field, message);
  };
  // A World maps every id up to the largest to a slot (4 bytes each): ids far beyond the particle
  // count would make that map huge.
  constexpr std::uint64_t spare_ids = std::uint64_t{1} << 26;
  const std::uint64_t top = *particles[*largest].id;
  if (top >= n + spare_ids)
    fail_at(*largest, "id " + std::to_string(top) + " leaves more than " + std::to_string(spare_ids) +
                          " ids unused below it (the engine keeps a slot for every id up to the largest): number the "
                          "particles from 0, below " + std::to_string(n + spare_ids));
  std::uint64_t next = top + 1;  // below n + spare_ids + n: far inside ParticleId
  for (std::size_t i = 0; i < n; ++i)
    if (!particles[i].id) particles[i].id = static_cast<ParticleId>(next++);
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return *particles[a].id < *particles[b].id; });
  for (std::size_t k = 1; k < n; ++k) {
    const std::size_t a = order[k - 1], b = order[k];
    if (*particles[a].id == *particles[b].id) {
      const ParticleSource& other = id_cells[a];
      fail_at(b, "id " + std::to_string(*particles[b].id) + " is also given in " + other.file + " line " +
                     std::to_string(other.line) + ": every particle needs its own id, a whole number from 0 to " +
                     std::to_string(std::numeric_limits<ParticleId>::max() - 1));
    }
  }
  std::vector<ParticleConfig> sorted_particles(n);
  std::vector<ParticleSource> sorted_sources(n);
  for (std::size_t k = 0; k < n; ++k) {
    sorted_particles[k] = std::move(particles[order[k]]);
    sorted_sources[k] = std::move(scene.sources[order[k]]);
  }
  particles = std::move(sorted_particles);
  scene.sources = std::move(sorted_sources);
}

}  // namespace loader

void check_initial_state(const Scene& scene) {
  const auto& particles = scene.world.particles;
  auto fail = [&](std::size_t p, const std::string& message) {
    const ParticleSource& s = p < scene.sources.size() ? scene.sources[p] : ParticleSource{scene.file, 0, 0, ""};
    throw InputError(s.file, s.line, s.column, s.field, message);
  };
  // Messages name particles by id (as outputs do); a scene made in code may leave ids to the World.
  const auto id_of = [&](std::size_t p) -> std::uint64_t {
    return particles[p].id.value_or(static_cast<ParticleId>(p));
  };
  std::vector<Vec3> position(particles.size());
  std::vector<Real> radius(particles.size());
  for (std::size_t p = 0; p < particles.size(); ++p) {
    position[p] = particles[p].position;
    radius[p] = particles[p].radius;
    if (scene.world.model.dimension == 2) position[p].z() = 0;
  }
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs pairs;
  grid.find_pairs(position, radius, 0, pairs);
  for (std::size_t a = 0; a < particles.size(); ++a)
    for (std::uint32_t k = pairs.row_start[a]; k < pairs.row_start[a + 1]; ++k) {
      const std::size_t b = pairs.partner[k];
      const Real overlap = radius[a] + radius[b] - (position[a] - position[b]).norm();
      const Real allowed = scene.max_initial_overlap * std::min(radius[a], radius[b]);
      if (overlap > allowed) {
        std::ostringstream m;
        m << "particle " << id_of(b) << " overlaps particle " << id_of(a) << " by " << overlap
          << " m at the start; at most " << allowed << " m (scene.max_initial_overlap = " << scene.max_initial_overlap
          << " of the smaller radius) is allowed";
        fail(b, m.str());
      }
    }
  MaterialTable materials(scene.world.materials, scene.world.contacts, scene.world.model.separation);
  Walls walls(scene.world.walls, materials);
  for (std::size_t p = 0; p < particles.size(); ++p)
    for (std::size_t w = 0; w < walls.count(); ++w) {
      const WallConfig& c = walls.config(w);
      WallTouch touch;
      bool outside = false;
      Real overlap = 0;
      std::vector<std::uint32_t> features(walls.touching_count(w, position[p], radius[p]));
      walls.touching_features(w, position[p], radius[p], features.data());
      for (const std::uint32_t f : features) {
        if (walls.touch(w, f, position[p], radius[p], touch)) overlap = std::max(overlap, touch.overlap);
      }
      if (c.kind == WallKind::plane) outside = (position[p] - walls.point(w)).dot(c.normal.normalized()) < 0;
      if (c.kind == WallKind::box && c.inside) {
        const Vec3 local = position[p] - walls.point(w);
        outside = (local.cwiseAbs() - c.half_extents).maxCoeff() > 0;
      }
      if (c.kind == WallKind::cylinder) {
        const Vec3 rel = position[p] - walls.point(w);
        const Vec3 axis = c.axis.normalized();
        outside = (rel - rel.dot(axis) * axis).norm() > c.radius && std::abs(rel.dot(axis)) <= 0.5 * c.length;
      }
      if (outside) fail(p, "particle " + std::to_string(id_of(p)) + " starts outside wall '" + c.name + "'");
      if (overlap > scene.max_initial_overlap * radius[p]) {
        std::ostringstream m;
        m << "particle " << id_of(p) << " overlaps wall '" << c.name << "' by " << overlap
          << " m at the start; at most " << scene.max_initial_overlap * radius[p]
          << " m (scene.max_initial_overlap of its radius) is allowed";
        fail(p, m.str());
      }
    }
}

}  // namespace dem
