#include "engine/state.h"

namespace dem {

ParticleIndex State::add(const Vec3& x, const Vec3& v, const Vec3& w, Real r, Real inv_m, Real inv_i,
                         std::uint16_t mat) {
  const auto slot = static_cast<ParticleIndex>(size());
  const auto new_id = static_cast<ParticleId>(index_of_id.size());
  id.push_back(new_id);
  index_of_id.push_back(slot);
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

}  // namespace dem
