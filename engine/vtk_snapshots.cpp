#include "engine/vtk_snapshots.h"

#include "engine/contacts.h"
#include "engine/world.h"

namespace dem {

ParticleSnapshot particle_snapshot(const World& world) {
  const State& s = world.state();
  const PairContacts& pairs = world.pair_contacts();
  const WallContacts& walls = world.wall_contacts();
  ParticleSnapshot snap;
  // Points in id order, whatever order the slots are in.
  std::vector<std::uint32_t> point_of_slot(s.size());
  for (const ParticleIndex p : s.index_of_id) {
    if (p == removed_slot) continue;
    point_of_slot[p] = static_cast<std::uint32_t>(snap.id.size());
    snap.id.push_back(s.id[p]);
    snap.position.push_back(s.position[p]);
    snap.velocity.push_back(s.velocity[p]);
    snap.angular_velocity.push_back(s.angular_velocity[p]);
    snap.radius.push_back(s.radius[p]);
    snap.level.push_back(s.level[p]);
    snap.force.push_back(s.force[p]);
    snap.torque.push_back(s.torque[p]);
    snap.material.push_back(s.material[p]);
  }
  snap.coordination.assign(s.size(), 0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    ++snap.coordination[point_of_slot[pairs.i[k]]];
    ++snap.coordination[point_of_slot[pairs.j[k]]];
  }
  for (std::size_t k = 0; k < walls.size(); ++k) ++snap.coordination[point_of_slot[walls.particle[k]]];
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
  for (std::uint32_t k : key_order(pairs.key)) {
    const ParticleIndex i = pairs.i[k], j = pairs.j[k];
    // The force is on i, the normal from j to i as the force loop computes it.
    add_contact(c, s.position[i], s.position[j], s.id[i], s.id[j], -1, pair_normal(s, i, j).n, pairs.force[k],
                pairs.overlap[k]);
  }
  for (std::uint32_t k : key_order(walls.key)) {
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
