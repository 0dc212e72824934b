#include "engine/state.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "engine/checks.h"

namespace dem {

ParticleIndex State::add(const Vec3& x, const Vec3& v, const Vec3& w, Real r, Real inv_m, Real inv_i,
                         std::uint16_t mat) {
  return add(next_id(), x, v, w, r, inv_m, inv_i, mat);
}

ParticleIndex State::add(ParticleId given_id, const Vec3& x, const Vec3& v, const Vec3& w, Real r, Real inv_m,
                         Real inv_i, std::uint16_t mat) {
  if (given_id < next_id() || given_id == std::numeric_limits<ParticleId>::max())
    throw std::invalid_argument("particle id " + std::to_string(given_id) +
                                " is taken or out of order: ids must increase (the next is at least " +
                                std::to_string(next_id()) + ") and stay below " +
                                std::to_string(std::numeric_limits<ParticleId>::max()));
  const auto slot = static_cast<ParticleIndex>(size());
  id.push_back(given_id);
  index_of_id.resize(std::size_t{given_id} + 1, removed_slot);
  index_of_id[given_id] = slot;
  position.push_back(x);
  velocity.push_back(v);
  angular_velocity.push_back(w);
  force.push_back(Vec3::Zero());
  torque.push_back(Vec3::Zero());
  radius.push_back(r);
  inv_mass.push_back(inv_m);
  inv_inertia.push_back(inv_i);
  material.push_back(mat);
  level.push_back(0);
  return slot;
}

void State::reserve(std::size_t n) {
  const auto room = [n](auto& v) { v.reserve(n); };
  room(id), room(position), room(velocity), room(angular_velocity), room(force), room(torque), room(radius);
  room(inv_mass), room(inv_inertia), room(material), room(level), room(index_of_id);
}

void State::remove(ParticleIndex slot) {
  const auto erase = [slot](auto& v) { v.erase(v.begin() + slot); };
  index_of_id[id[slot]] = removed_slot;
  erase(id), erase(position), erase(velocity), erase(angular_velocity), erase(force), erase(torque);
  erase(radius), erase(inv_mass), erase(inv_inertia), erase(material), erase(level);
  for (std::size_t s = slot; s < id.size(); ++s) index_of_id[id[s]] = static_cast<ParticleIndex>(s);
}

void State::permute(const std::vector<std::uint32_t>& order) {
  DEM_ASSERT(order.size() == size());
  // In place: the arrays keep their storage (embedding programs hold views of it).
  const auto reorder = [&order](auto& v) {
    const auto before = v;
    for (std::size_t q = 0; q < order.size(); ++q) v[q] = before[order[q]];
  };
  reorder(id), reorder(position), reorder(velocity), reorder(angular_velocity), reorder(force), reorder(torque);
  reorder(radius), reorder(inv_mass), reorder(inv_inertia), reorder(material), reorder(level);
  for (std::size_t q = 0; q < id.size(); ++q) index_of_id[id[q]] = static_cast<ParticleIndex>(q);
}

bool State::slots_follow_ids() const { return std::is_sorted(id.begin(), id.end()); }

void select_particles(const State& s, const std::vector<ParticleIndex>& members, State& out) {
  const std::size_t m = members.size();
  out.id.resize(m), out.position.resize(m), out.velocity.resize(m), out.angular_velocity.resize(m);
  out.force.resize(m), out.torque.resize(m), out.radius.resize(m), out.inv_mass.resize(m), out.inv_inertia.resize(m);
  out.material.resize(m), out.level.resize(m);
  out.index_of_id.clear();
  for (std::size_t q = 0; q < m; ++q) {
    const ParticleIndex p = members[q];
    out.id[q] = s.id[p];
    out.position[q] = s.position[p];
    out.velocity[q] = s.velocity[p];
    out.angular_velocity[q] = s.angular_velocity[p];
    out.force[q] = s.force[p];
    out.torque[q] = s.torque[p];
    out.radius[q] = s.radius[p];
    out.inv_mass[q] = s.inv_mass[p];
    out.inv_inertia[q] = s.inv_inertia[p];
    out.material[q] = s.material[p];
    out.level[q] = s.level[p];
  }
}

}  // namespace dem
