// The World's embedding API (docs/design.md, Embedding): running with a
// callback at sync times, reading particles by stable id and contact forces, and feeding and
// discharging particles between sync intervals.
// A population change, top to bottom:
//   State::add / State::remove (the others keep their slots' order, ids are never reused)
//   -> the removed particle's contacts dropped from both lists, the slots above it renumbered
//      (keys and history of every other contact untouched)
//   -> contact rows and the gather adjacency rebuilt -> per-particle forces re-summed from the
//      remaining contacts (the next half kick must not feel a removed neighbour)
//   -> candidate pairs rebuilt -> step doubling's per-particle arrays resized to the new count.
// Reads and writes the World's state, contact lists, energy books and doubling work; only between
// sync intervals. Threading: serial, except the gather and the candidate rebuild, which run in the
// World's arena under the rules of docs/design.md, Determinism; nothing here depends on the thread count.
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "engine/doubling_work.h"
#include "engine/materials.h"
#include "engine/scheduler.h"
#include "engine/world.h"

namespace dem {

// World::load is defined in scene_world.cpp: the core never calls the loader.

StepStatus World::run_until(Real t, const SyncCallback& on_sync) {
  while (time() < t) {
    const StepStatus status = advance_sync_interval();
    if (status != StepStatus::ok) return status;
    if (on_sync && !on_sync(*this)) break;
  }
  return StepStatus::ok;
}

// ---- reading -----------------------------------------------------------------------------------

std::optional<ParticleIndex> World::index_of(ParticleId id) const {
  if (id >= state_.index_of_id.size() || state_.index_of_id[id] == removed_slot) return std::nullopt;
  return state_.index_of_id[id];
}

namespace {

ParticleIndex live_slot(const std::optional<ParticleIndex>& slot, ParticleId id) {
  if (!slot) throw std::out_of_range("particle id " + std::to_string(id) + " is not in the world (never given or removed)");
  return *slot;
}

}  // namespace

const Vec3& World::position(ParticleId id) const { return state_.position[live_slot(index_of(id), id)]; }
const Vec3& World::velocity(ParticleId id) const { return state_.velocity[live_slot(index_of(id), id)]; }
const Vec3& World::angular_velocity(ParticleId id) const {
  return state_.angular_velocity[live_slot(index_of(id), id)];
}

std::vector<ContactForce> World::contact_forces() const {
  sync_pair_contacts();
  std::vector<ContactForce> out;
  out.reserve(pairs_.size() + wall_contacts_.size());
  const State& s = state_;
  for (std::uint32_t k : key_order(pairs_.key)) {
    const ParticleIndex i = pairs_.i[k], j = pairs_.j[k];
    // The contact point of the force loop (forces.cpp): mid-overlap on the line of centres.
    const Vec3 d = s.position[i] - s.position[j];
    const Real dist = d.norm();
    const Vec3 n = dist > 0 ? Vec3(d / dist) : Vec3(Vec3::UnitX());
    ContactForce c;
    c.particle = s.id[i];
    c.partner = s.id[j];
    c.force = pairs_.force[k];
    c.point = s.position[i] - (s.radius[i] - 0.5 * pairs_.overlap[k]) * n;
    c.overlap = pairs_.overlap[k];
    out.push_back(c);
  }
  for (std::uint32_t k : key_order(wall_contacts_.key)) {
    ContactForce c;
    c.particle = c.partner = s.id[wall_contacts_.particle[k]];
    c.wall = static_cast<int>(wall_contacts_.wall[k]);
    c.force = wall_contacts_.force[k];
    c.point = wall_contacts_.point[k];
    c.overlap = wall_contacts_.overlap[k];
    out.push_back(c);
  }
  return out;
}

std::optional<std::size_t> World::find_wall(const std::string& name) const {
  for (std::size_t w = 0; w < walls_.count(); ++w)
    if (walls_.config(w).name == name) return w;
  return std::nullopt;
}

std::vector<ParticleConfig> World::particles() const {
  std::vector<ParticleConfig> out;
  out.reserve(state_.size());
  const auto by_id = [](const ParticleConfig& c, ParticleId id) { return *c.id < id; };
  for (const ParticleIndex p : state_.index_of_id) {  // in id order
    if (p == removed_slot) continue;
    ParticleConfig c;
    c.id = state_.id[p];
    c.position = state_.position[p];
    c.velocity = state_.velocity[p];
    c.angular_velocity = state_.angular_velocity[p];
    c.radius = state_.radius[p];
    c.material = materials_.name(state_.material[p]);
    // config_.particles holds every particle ever added, each with its id, in id order.
    const auto given = std::lower_bound(config_.particles.begin(), config_.particles.end(), state_.id[p], by_id);
    if (given != config_.particles.end() && *given->id == state_.id[p]) {
      // particle_mass's rule: a given mass wins, else a given density, else the material's.
      if (given->mass > 0) c.mass = given->mass;
      else c.density = given->density > 0 ? given->density : materials_.density(state_.material[p]);
    } else {
      c.mass = 1 / state_.inv_mass[p];  // restored from a checkpoint of another population: as near as can be
    }
    out.push_back(std::move(c));
  }
  return out;
}

// ---- feed and discharge ------------------------------------------------------------------------

bool World::is_free(const Vec3& position, Real radius) const {
  Vec3 x = position;
  if (config_.model.dimension == 2) x.z() = 0;
  // The contact tests of contacts.cpp: centres closer than the sum of radii, walls by touching_count.
  for (std::size_t p = 0; p < state_.size(); ++p) {
    const Real reach = radius + state_.radius[p];
    if ((state_.position[p] - x).squaredNorm() < reach * reach) return false;
  }
  for (std::size_t w = 0; w < walls_.count(); ++w)
    if (walls_.touching_count(w, x, radius) > 0) return false;
  return true;
}

ParticleId World::add_particle(const ParticleConfig& p) {
  // The constructor's checks (world.cpp), then free space.
  if (!(p.radius > 0) || !std::isfinite(p.radius) || !p.position.allFinite() || !p.velocity.allFinite() ||
      !p.angular_velocity.allFinite())
    throw std::invalid_argument("add_particle: the particle needs a finite radius > 0 and finite position and velocities");
  const int mat = materials_.find(p.material);
  if (mat < 0) throw std::invalid_argument("add_particle: unknown material '" + p.material + "'");
  const int dim = config_.model.dimension;
  // Mass and inertia as World::add_particles (world.cpp).
  const Real mass = particle_mass(p, materials_.density(static_cast<std::uint16_t>(mat)), dim, config_.model.thickness);
  const Real inv_mass = std::isinf(mass) ? 0 : 1 / mass;
  const Real inv_inertia = inv_mass / (inertia_factor(dim) * p.radius * p.radius);
  Vec3 x = p.position, v = p.velocity, w = p.angular_velocity;
  if (dim == 2) {
    x.z() = 0;
    v.z() = 0;
    w.x() = w.y() = 0;
  }
  if (!is_free(x, p.radius))
    throw std::invalid_argument("add_particle: the particle would overlap a particle or a wall (see World::is_free)");
  if (p.id && *p.id < state_.next_id())
    throw std::invalid_argument("add_particle: id " + std::to_string(*p.id) +
                                " is taken or below a given id (ids are never reused): give " +
                                std::to_string(state_.next_id()) + " or more, or no id");
  const ParticleIndex slot = state_.add(p.id.value_or(state_.next_id()), x, v, w, p.radius, inv_mass, inv_inertia,
                                        static_cast<std::uint16_t>(mat));
  config_.particles.push_back(p);  // what it was given, for particles()
  config_.particles.back().id = state_.id[slot];
  if (spectra_) spectra_->classify(state_.id[slot], p.radius);
  // Energy books: the newcomer's energy joins the reference, as if it had been there from the start
  // (the same terms as energies()).
  if (is_audited(inv_mass)) {
    start_energies_.kinetic += 0.5 * v.squaredNorm() / inv_mass;
    if (kernels_.uses_rotation) start_energies_.rotational += 0.5 * w.squaredNorm() / inv_inertia;
    start_energies_.potential += -gravity_.dot(x) / inv_mass;
  }
  // Skin: a negative configured skin means 10% of the smallest radius (constructor).
  if (config_.broadphase.skin < 0) skin_ = skin_ > 0 ? std::min(skin_, 0.1 * p.radius) : 0.1 * p.radius;
  // Under doubling the next round widens the skin again as far as its reach needs (round_level): a
  // skin widened for a lone particle's uncapped rounds would otherwise outlive them.
  candidate_skin_ = doubling_ ? skin_ : std::max(candidate_skin_, skin_);
  if (doubling_) {
    const IntegratorConfig& c = config_.integrator;
    DoublingWork& d = *doubling_;
    state_.level[slot] = static_cast<std::int8_t>(std::clamp(0, c.level_min, c.level_max));  // as init_doubling
    d.skin_cap = std::max({d.skin_cap, skin_, 2 * p.radius});
    // A lighter particle may need finer contact steps: init_doubling's rule for this mass.
    Real k_max = 0;
    for (const ContactConfig& contact : config_.contacts) k_max = std::max(k_max, contact.normal_stiffness);
    if (k_max > 0 && inv_mass > 0)
      d.contact_level = std::min(d.contact_level, contact_resolving_level(k_max, 2 * inv_mass, scheduler_.dt_base(),
                                                                          c.level_min, c.level_max));
  }
  refresh_after_population_change();
  return state_.id[slot];
}

bool World::set_velocity(ParticleId id, const Vec3& velocity) {
  const std::optional<ParticleIndex> found = index_of(id);
  if (!found || !velocity.allFinite() || (config_.model.dimension == 2 && velocity.z() != 0)) return false;
  Vec3& v = state_.velocity[*found];
  const Real inv_mass = state_.inv_mass[*found];
  if (is_audited(inv_mass)) given_energy_ += 0.5 * (velocity.squaredNorm() - v.squaredNorm()) / inv_mass;
  v = velocity;
  return true;
}

bool World::remove_particle(ParticleId id) {
  const std::optional<ParticleIndex> found = index_of(id);
  if (!found) return false;
  const ParticleIndex slot = *found;
  const State& s = state_;
  sync_pair_contacts();
  // Energy books (serial, in contact order). Kinetic and rotational energy leave with the particle;
  // its potential energy leaves the reference, so the potential energy released stays that of the
  // particles while they were in the world.
  Real carried = 0;
  if (is_audited(s.inv_mass[slot])) {
    carried += 0.5 * s.velocity[slot].squaredNorm() / s.inv_mass[slot];
    if (kernels_.uses_rotation) carried += 0.5 * s.angular_velocity[slot].squaredNorm() / s.inv_inertia[slot];
    start_energies_.potential -= -gravity_.dot(s.position[slot]) / s.inv_mass[slot];
  }
  // Its contacts end: their springs' energy is carried out, what they dissipated stays dissipated
  // (Verlet books it per contact; the exact stepper keeps its own total).
  const bool contact_books = config_.integrator.method == Method::verlet;
  const auto renumber = [slot](ParticleIndex p) { return p > slot ? p - 1 : p; };
  std::size_t kept = 0;
  for (std::size_t k = 0; k < pairs_.size(); ++k) {
    if (pairs_.i[k] == slot || pairs_.j[k] == slot) {
      carried += pairs_.elastic[k];
      if (contact_books) ended_dissipation_ += pairs_.work[k] - pairs_.elastic[k];
      if (spectra_) spectra_->record_pair(pair_key(s.id[pairs_.i[k]], s.id[pairs_.j[k]]), pairs_.history(k), pairs_.work[k], pairs_.elastic[k]);
      continue;
    }
    copy_pair(pairs_, k, pairs_, kept);  // kept <= k: moves towards the front
    pairs_.i[kept] = renumber(pairs_.i[kept]);
    pairs_.j[kept] = renumber(pairs_.j[kept]);
    ++kept;
  }
  pairs_.resize(kept);
  kept = 0;
  for (std::size_t k = 0; k < wall_contacts_.size(); ++k) {
    if (wall_contacts_.particle[k] == slot) {
      carried += wall_contacts_.elastic[k];
      if (contact_books) ended_dissipation_ += wall_contacts_.work[k] - wall_contacts_.elastic[k];
      if (spectra_)
        spectra_->record_wall(wall_contacts_.key[k], wall_contacts_.history[k], wall_contacts_.work[k], wall_contacts_.elastic[k]);
      continue;
    }
    copy_wall(wall_contacts_, k, wall_contacts_, kept);
    wall_contacts_.particle[kept] = renumber(wall_contacts_.particle[kept]);
    ++kept;
  }
  wall_contacts_.resize(kept);
  removed_energy_ += carried;
  // The exact stepper's contact histories are keyed by id (a pair's by both).
  std::erase_if(exact_work_.history, [id](const ExactHistoryRecord& r) { return exact_history_involves(r.key, id); });
  state_.remove(slot);
  refresh_after_population_change();
  return true;
}

void World::refresh_after_population_change() {
  sync_pair_contacts();
  pair_contacts_changed();
  const std::size_t n = state_.size();
  wall_lists_.clear();
  pairs_.index_rows(n);
  build_pair_adjacency(n, pairs_, adjacency_);
  std::vector<std::uint32_t>& wall_start = adjacency_.wall_start;  // wall contacts are sorted by particle
  wall_start.assign(n + 1, 0);
  for (std::size_t k = 0; k < wall_contacts_.size(); ++k) ++wall_start[wall_contacts_.particle[k] + 1];
  for (std::size_t p = 0; p < n; ++p) wall_start[p + 1] += wall_start[p];
  arena_->execute([&] {
    gather_forces(state_, pairs_, wall_contacts_, adjacency_, kernels_.uses_rotation, config_.model.dimension);
    rebuild_candidates();
  });
  if (doubling_) {
    // Rounds size their islands from the state; these two persist between rounds.
    doubling_->next = state_;
    doubling_->excursion.assign(n, 0);
  }
}

}  // namespace dem
