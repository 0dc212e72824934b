#include "engine/contacts.h"

#include <algorithm>
#include <limits>

#include "engine/checks.h"
#include "engine/parallel.h"

namespace dem {

void PairContacts::resize(std::size_t n) {
  key.resize(n);
  i.resize(n);
  j.resize(n);
  constants.resize(n);
  history.resize(n);
  overlap.resize(n);
  work.resize(n);
  elastic.resize(n);
  force.resize(n);
  torque_i.resize(n);
  torque_j.resize(n);
}

void PairContacts::index_rows(std::size_t particle_count) {
  row_start.assign(particle_count + 1, 0);
  for (std::size_t k = 0; k < size(); ++k) ++row_start[std::min(i[k], j[k]) + 1];
  for (std::size_t a = 0; a < particle_count; ++a) row_start[a + 1] += row_start[a];
}

void WallContacts::resize(std::size_t n) {
  key.resize(n);
  particle.resize(n);
  wall.resize(n);
  feature.resize(n);
  constants.resize(n);
  history.resize(n);
  overlap.resize(n);
  work.resize(n);
  elastic.resize(n);
  point.resize(n);
  force.resize(n);
  torque.resize(n);
  rolling_torque.resize(n);
}

namespace {

/// Two immovable particles (inverse mass 0 both) have no finite effective mass: never a contact.
bool overlapping(const State& s, ParticleIndex a, ParticleIndex b) {
  if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) return false;
  const Real reach = s.radius[a] + s.radius[b];
  return (s.position[a] - s.position[b]).squaredNorm() < reach * reach;
}

/// Books the step on which a contact parted, now that it has left the list: its normal spring gives
/// back what it held (from delta_last to 0, as the onset is booked from 0: contact_law.h), and its
/// dashpot, whose last force velocity Verlet still applies over that step, is booked by the
/// trapezoid over the step, (F_n - k delta_last) (delta_now - delta_last) / 2. Under force_zero a
/// clamped force holds no spring and exerts none. The tangential and rolling springs keep the old
/// rule: what they hold is taken as given back.
void book_release(Real normal_force, Real overlap_now, const LawConstants& law, Real overlap_last,
                  ContactHistory& history, Real& work, Real& elastic) {
  const Real spring = history.normal_elastic > 0 ? law.k_n * overlap_last : 0;
  const Real release = 0.5 * (normal_force - spring) * (overlap_now - overlap_last) - history.normal_elastic;
  work += release;
  history.normal_work += release;
  elastic -= history.normal_elastic;
  history.normal_elastic = 0;
}

/// Books the release step of a pair contact that has just ended (book_release) and returns what the
/// contact dissipated over its life [J].
Real end_pair_contact(const State& s, PairContacts& c, std::uint32_t k) {
  const ParticleIndex i = c.i[k], j = c.j[k];
  const Vec3 d = s.position[i] - s.position[j];
  const Real dist = d.norm();
  const Vec3 n = dist > 0 ? Vec3(d / dist) : Vec3(Vec3::UnitX());
  const Real overlap_now = s.radius[i] + s.radius[j] - dist;
  book_release(c.force[k].dot(n), overlap_now, c.constants[k], c.overlap[k], c.history[k], c.work[k], c.elastic[k]);
  return c.work[k] - c.elastic[k];
}

/// The same for a wall contact (the wall list's books are a difference of sums). The wall's
/// geometry at a larger radius gives the (negative) overlap now: a feature touched at radius r is
/// touched at any larger one (walls.h). A particle more than its radius clear of the feature after
/// one step keeps the old rule.
void end_wall_contact(const State& s, const Walls& walls, WallContacts& c, std::size_t k) {
  const ParticleIndex p = c.particle[k];
  const Real r = s.radius[p];
  WallTouch touch;
  if (!walls.touch(c.wall[k], c.feature[k], s.position[p], 2 * r, touch)) return;
  book_release(c.force[k].dot(touch.normal), touch.overlap - r, c.constants[k], c.overlap[k], c.history[k],
               c.work[k], c.elastic[k]);
}

/// Index of `key` in the ascending `keys`, or -1.
std::ptrdiff_t find_key(const std::vector<std::uint64_t>& keys, std::uint64_t key) {
  const auto it = std::lower_bound(keys.begin(), keys.end(), key);
  return (it != keys.end() && *it == key) ? it - keys.begin() : -1;
}

}  // namespace

Real live_dissipation(const std::vector<Real>& work, const std::vector<Real>& elastic) {
  return block_sum<Real>(work.size(), [&](std::size_t k) { return work[k] - elastic[k]; });
}

Real update_pair_contacts(const State& s, const broadphase::CandidatePairs& candidates, const MaterialTable& materials,
                          PairContacts& contacts, ContactWorkspace& work) {
  const std::size_t n = candidates.row_count();
  DEM_ASSERT(n == s.size());
  work.count.resize(n);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t c = 0;
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k)
      c += overlapping(s, static_cast<ParticleIndex>(a), candidates.partner[k]) ? 1 : 0;
    work.count[a] = c;
  });
  exclusive_scan(work.count, work.offset);
  PairContacts& fresh = work.pairs;
  fresh.resize(work.offset[n]);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t slot = work.offset[a];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      if (!overlapping(s, static_cast<ParticleIndex>(a), b)) continue;
      // Slots follow ids; with slots in id order a row of ascending partners is ascending in key.
      const bool a_first = s.id[a] < s.id[b];
      fresh.i[slot] = a_first ? static_cast<ParticleIndex>(a) : b;
      fresh.j[slot] = a_first ? b : static_cast<ParticleIndex>(a);
      fresh.key[slot] = pair_key(s.id[a], s.id[b]);
      ++slot;
    }
  });
  DEM_VALIDATE(std::is_sorted(fresh.key.begin(), fresh.key.end()));
  fresh.row_start = work.offset;
  if (contacts.row_start.size() != n + 1) contacts.index_rows(n);
  // Inherit history row by row: old and new contacts of a row are both ascending in key, so a
  // linear merge pairs them up (streaming, no search); old ones left over have ended.
  work.row_ended.resize(n);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t old = contacts.row_start[a];
    const std::uint32_t old_end = contacts.row_start[a + 1];
    Real ended = 0;
    for (std::uint32_t k = fresh.row_start[a]; k < fresh.row_start[a + 1]; ++k) {
      while (old < old_end && contacts.key[old] < fresh.key[k]) ended += end_pair_contact(s, contacts, old++);
      if (old < old_end && contacts.key[old] == fresh.key[k]) {
        fresh.constants[k] = contacts.constants[old];
        fresh.history[k] = contacts.history[old];
        fresh.work[k] = contacts.work[old];
        fresh.elastic[k] = contacts.elastic[old];
        fresh.overlap[k] = contacts.overlap[old];
        fresh.force[k] = contacts.force[old];
        ++old;
        continue;
      }
      const ParticleIndex i = fresh.i[k], j = fresh.j[k];
      const EffectiveMasses m = effective_masses(s.inv_mass[i], s.inv_inertia[i], s.radius[i], s.inv_mass[j],
                                                 s.inv_inertia[j], s.radius[j]);
      fresh.constants[k] = materials.constants(materials.pair_class(s.material[i], s.material[j]), m);
      fresh.history[k] = ContactHistory{};
      fresh.work[k] = 0;
      fresh.elastic[k] = 0;
      fresh.overlap[k] = 0;
      fresh.force[k].setZero();
    }
    for (; old < old_end; ++old) ended += end_pair_contact(s, contacts, old);
    work.row_ended[a] = ended;
  });
  const Real ended = block_sum<Real>(n, [&](std::size_t a) { return work.row_ended[a]; });
  std::swap(contacts, fresh);
  return ended;
}

Real update_wall_contacts(const State& s, const Walls& walls, const MaterialTable& materials, WallContacts& contacts,
                          ContactWorkspace& work, std::vector<std::uint32_t>& wall_start) {
  const std::size_t n = s.size();
  work.count.resize(n);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t c = 0;
    if (s.inv_mass[p] > 0)
      for (std::size_t w = 0; w < walls.count(); ++w) c += walls.touching_count(w, s.position[p], s.radius[p]);
    work.count[p] = c;
  });
  exclusive_scan(work.count, wall_start);
  WallContacts& fresh = work.walls;
  fresh.resize(wall_start[n]);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t slot = wall_start[p];
    for (std::size_t w = 0; w < walls.count(); ++w) {
      // The features go straight into this particle's slots, whose number the count above fixed.
      const std::uint32_t touched =
          s.inv_mass[p] > 0 ? walls.touching_features(w, s.position[p], s.radius[p], fresh.feature.data() + slot) : 0;
      for (std::uint32_t q = 0; q < touched; ++q) {
        const std::uint32_t f = fresh.feature[slot];
        fresh.key[slot] = wall_key(s.id[p], static_cast<std::uint32_t>(w), f);
        fresh.particle[slot] = static_cast<ParticleIndex>(p);
        fresh.wall[slot] = static_cast<std::uint32_t>(w);
        const std::ptrdiff_t old = find_key(contacts.key, fresh.key[slot]);
        if (old >= 0) {
          fresh.constants[slot] = contacts.constants[old];
          fresh.history[slot] = contacts.history[old];
          fresh.work[slot] = contacts.work[old];
          fresh.elastic[slot] = contacts.elastic[old];
          fresh.overlap[slot] = contacts.overlap[old];
          fresh.force[slot] = contacts.force[old];
        } else {
          const EffectiveMasses m = effective_masses(s.inv_mass[p], s.inv_inertia[p], s.radius[p], 0, 0,
                                                     std::numeric_limits<Real>::infinity());
          fresh.constants[slot] = materials.constants(materials.pair_class(s.material[p], walls.material(w)), m);
          fresh.history[slot] = ContactHistory{};
          fresh.work[slot] = 0;
          fresh.elastic[slot] = 0;
          fresh.overlap[slot] = 0;
          fresh.force[slot].setZero();
        }
        ++slot;
      }
    }
  });
  DEM_VALIDATE(std::is_sorted(fresh.key.begin(), fresh.key.end()));
  parallel_for(contacts.size(), [&](std::size_t k) {
    if (find_key(fresh.key, contacts.key[k]) < 0) end_wall_contact(s, walls, contacts, k);
  });
  const Real ended = live_dissipation(contacts.work, contacts.elastic) - live_dissipation(fresh.work, fresh.elastic);
  std::swap(contacts, fresh);
  return ended;
}

void build_pair_adjacency(std::size_t particle_count, const PairContacts& contacts, ContactAdjacency& adjacency) {
  auto& start = adjacency.pair_start;
  start.assign(particle_count + 1, 0);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    ++start[contacts.i[k] + 1];
    ++start[contacts.j[k] + 1];
  }
  for (std::size_t p = 0; p < particle_count; ++p) start[p + 1] += start[p];
  adjacency.pair_entry.resize(start[particle_count]);
  // Contacts are sorted by (smaller id, larger id): walking them in order appends, for every
  // particle, first its smaller-id partners ascending, then its larger-id partners ascending.
  auto& cursor = adjacency.cursor;
  cursor.assign(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    adjacency.pair_entry[cursor[contacts.i[k]]++] = static_cast<std::uint32_t>(k << 1);
    adjacency.pair_entry[cursor[contacts.j[k]]++] = static_cast<std::uint32_t>((k << 1) | 1);
  }
}

}  // namespace dem
