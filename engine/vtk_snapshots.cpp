#include "engine/vtk_snapshots.h"

#include "engine/contacts.h"
#include "engine/world.h"

namespace dem {

ParticleSnapshot particle_snapshot(const World& world) {
  const State& s = world.state();
  const PairContacts& pairs = world.pair_contacts();
  const WallContacts& walls = world.wall_contacts();
  ParticleSnapshot snap;
  const std::size_t n = s.size();
  snap.id.assign(s.id.begin(), s.id.end());
  snap.position.assign(s.position.begin(), s.position.end());
  snap.velocity.assign(s.velocity.begin(), s.velocity.end());
  snap.angular_velocity.assign(s.angular_velocity.begin(), s.angular_velocity.end());
  snap.radius.assign(s.radius.begin(), s.radius.end());
  snap.level.assign(s.level.begin(), s.level.end());
  snap.force.assign(s.force.begin(), s.force.end());
  snap.torque.assign(s.torque.begin(), s.torque.end());
  snap.material.assign(s.material.begin(), s.material.end());
  snap.coordination.assign(n, 0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    ++snap.coordination[pairs.i[k]];
    ++snap.coordination[pairs.j[k]];
  }
  for (std::size_t k = 0; k < walls.size(); ++k) ++snap.coordination[walls.particle[k]];
  for (std::size_t m = 0; m < world.materials().material_count(); ++m) {
    snap.material_names.push_back(world.materials().name(static_cast<std::uint16_t>(m)));
  }
  return snap;
}

namespace {

// Appends one contact whose force `force` acts on the particle at `from`, the normal `normal` pointing
// from the other side towards it.
void add_contact(ContactSnapshot& c, const Vec3& from, const Vec3& to, std::int64_t id_a, std::int64_t id_b,
                 std::int32_t wall, const Vec3& normal, const Vec3& force, Real overlap) {
  const Real along = force.dot(normal);
  const Vec3 normal_force = along * normal;
  c.from.push_back(from);
  c.to.push_back(to);
  c.id_a.push_back(id_a);
  c.id_b.push_back(id_b);
  c.wall.push_back(wall);
  c.normal_force.push_back(along);
  c.normal_force_vector.push_back(normal_force);
  c.tangential_force_vector.push_back(force - normal_force);
  c.overlap.push_back(overlap);
}

}  // namespace

ContactSnapshot contact_snapshot(const World& world) {
  const State& s = world.state();
  const PairContacts& pairs = world.pair_contacts();
  const WallContacts& walls = world.wall_contacts();
  ContactSnapshot c;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const ParticleIndex i = pairs.i[k], j = pairs.j[k];
    // The force is on i, the normal from j to i as the force loop computes it.
    add_contact(c, s.position[i], s.position[j], s.id[i], s.id[j], -1, pair_normal(s, i, j).n, pairs.force[k],
                pairs.overlap[k]);
  }
  for (std::size_t k = 0; k < walls.size(); ++k) {
    const ParticleIndex p = walls.particle[k];
    const Vec3 d = s.position[p] - walls.point[k];
    const Real distance = d.norm();
    const Vec3 normal = distance > 0 ? Vec3(d / distance) : Vec3::Zero();
    add_contact(c, s.position[p], walls.point[k], s.id[p], -1, static_cast<std::int32_t>(walls.wall[k]), normal,
                walls.force[k], walls.overlap[k]);
  }
  return c;
}

}  // namespace dem
