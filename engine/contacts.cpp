#include "engine/contacts.h"

#include <algorithm>
#include <limits>

#include "engine/capacity.h"
#include "engine/checks.h"
#include "engine/parallel.h"

namespace dem {

void PairContacts::resize(std::size_t n) {
  for_each_array(parts, [&](auto field) { resize_with_headroom(this->*field, n); });
}

ContactHistory PairContacts::history(std::size_t k) const {
  ContactHistory h;
  if (parts.friction) h.tangential_spring = tangential_spring[k];
  if (parts.rolling) h.rolling_spring = rolling_spring[k];
  h.mode = mode[k];
  if (parts.books) {
    h.normal_work = books[k].normal_work;
    h.normal_elastic = books[k].normal_elastic;
    h.impact_energy = books[k].impact_energy;
  }
  return h;
}

void PairContacts::set_history(std::size_t k, const ContactHistory& h) {
  if (parts.friction) tangential_spring[k] = h.tangential_spring;
  if (parts.rolling) rolling_spring[k] = h.rolling_spring;
  mode[k] = h.mode;
  if (parts.books) books[k] = {h.normal_work, h.normal_elastic, h.impact_energy};
}

void copy_pair(const PairContacts& a, std::size_t from, PairContacts& b, std::size_t to) {
  PairContacts::for_each_array(a.parts, [&](auto field) { (b.*field)[to] = (a.*field)[from]; });
}

void PairContacts::index_rows(std::size_t particle_count) {
  row_start.assign(particle_count + 1, 0);
  for (std::size_t k = 0; k < size(); ++k) ++row_start[i[k] + 1];
  for (std::size_t a = 0; a < particle_count; ++a) row_start[a + 1] += row_start[a];
}

std::vector<std::uint32_t> key_order(const std::vector<std::uint64_t>& keys) {
  std::vector<std::uint32_t> order(keys.size());
  for (std::size_t k = 0; k < keys.size(); ++k) order[k] = static_cast<std::uint32_t>(k);
  if (!std::is_sorted(keys.begin(), keys.end()))
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return keys[a] < keys[b]; });
  return order;
}

bool wall_keys_ascend_along_particles(const WallContacts& c) {
  for (std::size_t k = 1; k < c.size(); ++k)
    if (c.particle[k] < c.particle[k - 1] || (c.particle[k] == c.particle[k - 1] && !(c.key[k - 1] < c.key[k])))
      return false;
  return true;
}

bool keys_ascend_along_rows(const PairContacts& c) {
  for (std::size_t a = 0; a + 1 < c.row_start.size(); ++a)
    if (!std::is_sorted(c.key.begin() + c.row_start[a], c.key.begin() + c.row_start[a + 1])) return false;
  return true;
}

void WallContacts::resize(std::size_t n) {
  for_each_array([&](auto field) { resize_with_headroom(this->*field, n); });
}

void copy_wall(const WallContacts& a, std::size_t from, WallContacts& b, std::size_t to) {
  WallContacts::for_each_array([&](auto field) { (b.*field)[to] = (a.*field)[from]; });
}

namespace {

/// The work of the step on which a contact parted, booked now that it has left the list. Velocity
/// Verlet still applies the contact's last force over that step, as it applied the first one over
/// the step on which the contact formed. Both are booked for the normal spring from delta = 0
/// (contact_law.h, onset): the spring gives back what it held, which its books already take as
/// given back; the dashpot's share of the last force, F_n - k delta_last, is booked by the trapezoid
/// over the step to delta_now. A force_zero contact whose force is clamped (zero) exerts none. The
/// tangential and rolling springs keep the old rule: what they hold is taken as given back.
Real release_work(Real normal_force, Real k_n, Real overlap_now, Real overlap_last) {
  const Real spring = normal_force != 0 ? k_n * overlap_last : 0;
  return 0.5 * (normal_force - spring) * (overlap_now - overlap_last);
}

/// Books the release step of pair contact k of row a (its smaller slot) and returns what the contact
/// dissipated over its life [J]. The old slots i, j have been overwritten with the new list's by
/// now: the partner is found by id among row a's candidates (a pair that has just parted is within
/// the skin); should it not be there, the release step stays unbooked.
Real end_pair_contact(const State& s, const broadphase::CandidatePairs& candidates, const MaterialTable& materials,
                      ParticleIndex a, PairContacts& c, std::uint32_t k) {
  const ParticleId lo = static_cast<ParticleId>(c.key[k] >> 32), hi = static_cast<ParticleId>(c.key[k] & 0xffffffffu);
  const ParticleId partner = s.id[a] == lo ? hi : lo;
  for (std::uint32_t q = candidates.row_start[a]; q < candidates.row_start[a + 1]; ++q) {
    const ParticleIndex b = candidates.partner[q];
    if (s.id[b] != partner) continue;
    const ParticleIndex i = s.id[a] == lo ? a : b, j = s.id[a] == lo ? b : a;  // the force is on i
    return release_pair_contact(s, materials, i, j, c, k);
  }
  return c.work[k] - c.elastic[k];
}

/// The same for a wall contact (the wall list's books are a difference of sums). The wall's
/// geometry at a larger radius gives the (negative) overlap now: a feature touched at radius r is
/// touched at any larger one (walls.h). A particle more than its radius clear of the feature after
/// one step keeps the old rule.
void end_wall_contact(const State& s, const Walls& walls, const MaterialTable& materials, WallContacts& c,
                      std::size_t k) {
  const ParticleIndex p = c.particle[k];
  const Real r = s.radius[p];
  WallTouch touch;
  if (!walls.touch(c.wall[k], c.feature[k], s.position[p], 2 * r, touch)) return;
  const Real k_n = materials.params(materials.pair_class(s.material[p], walls.material(c.wall[k]))).k_n;
  const Real release = release_work(c.force[k].dot(touch.normal), k_n, touch.overlap - r, c.overlap[k]);
  c.work[k] += release;
  c.history[k].normal_work += release;
}

/// Index of particle p's contact with `key` in a wall list (ordered by particle slot, then key), or -1.
std::ptrdiff_t find_wall_contact(const WallContacts& c, ParticleIndex p, std::uint64_t key) {
  std::size_t lo = 0, hi = c.size();
  while (lo < hi) {  // the first contact not before (p, key)
    const std::size_t mid = lo + (hi - lo) / 2;
    if (c.particle[mid] < p || (c.particle[mid] == p && c.key[mid] < key))
      lo = mid + 1;
    else
      hi = mid;
  }
  return lo < c.size() && c.particle[lo] == p && c.key[lo] == key ? static_cast<std::ptrdiff_t>(lo) : -1;
}

}  // namespace

Real release_pair_contact(const State& s, const MaterialTable& materials, ParticleIndex i, ParticleIndex j,
                          PairContacts& c, std::size_t k) {
  const PairNormal g = pair_normal(s, i, j);
  const Real k_n = materials.params(materials.pair_class(s.material[i], s.material[j])).k_n;
  const Real release = release_work(c.force[k].dot(g.n), k_n, s.radius[i] + s.radius[j] - g.distance, c.overlap[k]);
  c.work[k] += release;
  if (c.parts.books) c.books[k].normal_work += release;
  return c.work[k] - c.elastic[k];
}

void reset_pair_contact(PairContacts& c, std::size_t k) {
  c.set_history(k, ContactHistory{});
  c.work[k] = 0;
  c.elastic[k] = 0;
  c.overlap[k] = 0;
  c.force[k].setZero();
}

Real live_dissipation(const std::vector<Real>& work, const std::vector<Real>& elastic) {
  return block_sum<Real>(work.size(), [&](std::size_t k) { return work[k] - elastic[k]; });
}

namespace {

constexpr std::uint32_t no_source = 0xffffffffu;  // a new contact: nothing to inherit
constexpr std::size_t carry_chunk = 4096;          // contacts moved per pass of two parallel loops

// Moves what the surviving contacts carry from their old slots to their new ones, in place. Sources
// ascend with the new slots (both lists are in key order), so a contact moving to the front never
// overwrites an old slot that one moving to the back has still to read, nor the reverse; those moving
// to the front go front to back, those moving to the back go back to front, a chunk at a time
// through `carry` (within a chunk reads and writes may overlap). New contacts start empty, last.
void move_carried(PairContacts& c, const std::vector<std::uint32_t>& source, PairContacts& carry) {
  const std::size_t m = source.size();
  carry.parts = c.parts;
  const std::size_t chunk = std::min(m, carry_chunk);  // a small list needs no full chunk
  PairContacts::for_each_carried(c.parts, [&](auto field) { (carry.*field).resize(chunk); });
  const auto move_chunk = [&](std::size_t k0, std::size_t k1, auto&& moves) {
    parallel_for(k1 - k0, [&](std::size_t q) {
      if (!moves(k0 + q)) return;
      const std::size_t from = source[k0 + q];
      PairContacts::for_each_carried(c.parts, [&](auto field) { (carry.*field)[q] = (c.*field)[from]; });
    });
    parallel_for(k1 - k0, [&](std::size_t q) {
      if (!moves(k0 + q)) return;
      PairContacts::for_each_carried(c.parts, [&](auto field) { (c.*field)[k0 + q] = (carry.*field)[q]; });
    });
  };
  const auto to_front = [&](std::size_t k) { return source[k] != no_source && source[k] > k; };
  const auto to_back = [&](std::size_t k) { return source[k] != no_source && source[k] < k; };
  for (std::size_t k0 = 0; k0 < m; k0 += carry_chunk) move_chunk(k0, std::min(m, k0 + carry_chunk), to_front);
  for (std::size_t k1 = m; k1 > 0;) {
    const std::size_t k0 = k1 - std::min(k1, carry_chunk);
    move_chunk(k0, k1, to_back);
    k1 = k0;
  }
  parallel_for(m, [&](std::size_t k) {
    if (source[k] == no_source) reset_pair_contact(c, k);
  });
}

}  // namespace

Real update_pair_contacts(const State& s, const broadphase::CandidatePairs& candidates, const MaterialTable& materials,
                          PairContacts& contacts, ContactWorkspace& work, const EndedPairsHook& on_ended) {
  const std::size_t n = candidates.row_count();
  DEM_ASSERT(n == s.size());
  DEM_VALIDATE(s.slots_follow_ids());  // the runs that use this list keep slots in id order
  work.count.resize(n);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t c = 0;
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k)
      c += pair_touches(s, static_cast<ParticleIndex>(a), candidates.partner[k]) ? 1 : 0;
    work.count[a] = c;
  });
  exclusive_scan(work.count, work.offset);
  const std::vector<std::uint32_t>& row_start = work.offset;  // of the new list
  const std::size_t m = row_start[n];
  if (contacts.row_start.size() != n + 1) contacts.index_rows(n);  // the last use of the old i, j
  resize_with_headroom(work.key, m), resize_with_headroom(contacts.i, m), resize_with_headroom(contacts.j, m);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t slot = row_start[a];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      if (!pair_touches(s, static_cast<ParticleIndex>(a), b)) continue;
      // Slots follow ids; with slots in id order a row of ascending partners is ascending in key.
      const bool a_first = s.id[a] < s.id[b];
      contacts.i[slot] = a_first ? static_cast<ParticleIndex>(a) : b;
      contacts.j[slot] = a_first ? b : static_cast<ParticleIndex>(a);
      work.key[slot] = pair_key(s.id[a], s.id[b]);
      ++slot;
    }
  });
  DEM_VALIDATE(std::is_sorted(work.key.begin(), work.key.end()));
  // Match row by row: old and new contacts of a row are both ascending in key, so a linear merge
  // pairs them up (streaming, no search); old ones left over have ended.
  resize_with_headroom(work.source, m);
  work.row_ended.resize(n);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t old = contacts.row_start[a];
    const std::uint32_t old_end = contacts.row_start[a + 1];
    Real ended = 0;
    for (std::uint32_t k = row_start[a]; k < row_start[a + 1]; ++k) {
      while (old < old_end && contacts.key[old] < work.key[k])
        ended += end_pair_contact(s, candidates, materials, static_cast<ParticleIndex>(a), contacts, old++);
      const bool inherits = old < old_end && contacts.key[old] == work.key[k];
      work.source[k] = inherits ? old++ : no_source;
    }
    for (; old < old_end; ++old)
      ended += end_pair_contact(s, candidates, materials, static_cast<ParticleIndex>(a), contacts, old);
    work.row_ended[a] = ended;
  });
  const Real ended = block_sum<Real>(n, [&](std::size_t a) { return work.row_ended[a]; });
  if (on_ended) on_ended(contacts, work.key);
  const std::size_t reach = std::max(contacts.size(), m);  // old slots are read, new ones written
  PairContacts::for_each_carried(contacts.parts, [&](auto field) { resize_with_headroom(contacts.*field, reach); });
  move_carried(contacts, work.source, work.carry);
  contacts.key.swap(work.key);
  contacts.row_start.swap(work.offset);
  contacts.resize(m);  // drops the old tail; torques wait for the force loop
  return ended;
}

Real update_wall_contacts(const State& s, const Walls& walls, const MaterialTable& materials, WallContacts& contacts,
                          ContactWorkspace& work, std::vector<std::uint32_t>& wall_start, const WallLists* lists,
                          std::vector<EndedContact>* ended_log) {
  const std::size_t n = s.size();
  // Calls visit(w) for each wall particle p is tested against, in ascending order.
  const auto for_each_wall = [&](std::size_t p, auto&& visit) {
    if (s.inv_mass[p] == 0) return;
    if (lists == nullptr) {
      for (std::size_t w = 0; w < walls.count(); ++w) visit(w);
      return;
    }
    for (std::uint32_t k = lists->row_start(p); k < lists->row_start(p + 1); ++k) visit(lists->wall(k));
  };
  // With lists, only the particles they list are visited (the rest touch no wall and count 0); in
  // ascending order either way, so the contacts come out in key order.
  DEM_ASSERT(!lists || lists->particle_count() == n);
  const std::size_t visited = lists ? lists->listed_particles().size() : n;
  const auto particle = [&](std::size_t v) -> std::size_t { return lists ? lists->listed_particles()[v] : v; };
  if (visited < n) work.count.assign(n, 0);
  else work.count.resize(n);
  // Counting keeps each particle's first touches (wall, feature, geometry) in its own stretch of
  // `found`: filling copies them instead of testing again.
  constexpr std::uint32_t kept = wall_touches_kept;
  work.found.resize(visited * kept);
  parallel_for(visited, [&](std::size_t v) {
    const std::size_t p = particle(v);
    WallTouchFound* found = work.found.data() + v * kept;
    std::uint32_t features[kept];
    WallTouch touches[kept];
    std::uint32_t c = 0;
    for_each_wall(p, [&](std::size_t w) {
      const std::uint32_t room = c < kept ? kept - c : 0;
      const std::uint32_t touched = walls.touching_features(w, s.position[p], s.radius[p], features, touches, room);
      for (std::uint32_t q = 0; q < std::min(touched, room); ++q)
        found[c + q] = {touches[q], static_cast<std::uint32_t>(w), features[q]};
      c += touched;
    });
    work.count[p] = c;
  });
  exclusive_scan(work.count, wall_start);
  WallContacts& fresh = work.walls;
  fresh.resize(wall_start[n]);
  work.wall_touch.resize(wall_start[n]);
  parallel_for(visited, [&](std::size_t v) {
    const std::size_t p = particle(v);
    const std::uint32_t first = wall_start[p], end = wall_start[p + 1];
    if (end - first <= kept) {
      const WallTouchFound* found = work.found.data() + v * kept;
      for (std::uint32_t slot = first; slot < end; ++slot) {
        fresh.wall[slot] = found[slot - first].wall;
        fresh.feature[slot] = found[slot - first].feature;
        work.wall_touch[slot] = found[slot - first].touch;
      }
    } else {
      // More touches than were kept: the features and geometry go straight into this particle's
      // slots, whose number the count above fixed.
      std::uint32_t slot = first;
      for_each_wall(p, [&](std::size_t w) {
        const std::uint32_t touched = std::min(
            walls.touching_features(w, s.position[p], s.radius[p], fresh.feature.data() + slot,
                                    work.wall_touch.data() + slot, end - slot),
            end - slot);
        for (std::uint32_t q = 0; q < touched; ++q) fresh.wall[slot + q] = static_cast<std::uint32_t>(w);
        slot += touched;
      });
      DEM_ASSERT(slot == end);  // the same tests as the count's
    }
    for (std::uint32_t slot = first; slot < end; ++slot) {
      fresh.key[slot] = wall_key(s.id[p], fresh.wall[slot], fresh.feature[slot]);
      fresh.particle[slot] = static_cast<ParticleIndex>(p);
      const std::ptrdiff_t old = find_wall_contact(contacts, static_cast<ParticleIndex>(p), fresh.key[slot]);
      if (old >= 0) {
        fresh.history[slot] = contacts.history[old];
        fresh.work[slot] = contacts.work[old];
        fresh.elastic[slot] = contacts.elastic[old];
        fresh.overlap[slot] = contacts.overlap[old];
        fresh.force[slot] = contacts.force[old];
      } else {
        fresh.history[slot] = ContactHistory{};
        fresh.work[slot] = 0;
        fresh.elastic[slot] = 0;
        fresh.overlap[slot] = 0;
        fresh.force[slot].setZero();
      }
    }
  });
  DEM_VALIDATE(wall_keys_ascend_along_particles(fresh));
  parallel_for(contacts.size(), [&](std::size_t k) {
    if (find_wall_contact(fresh, contacts.particle[k], contacts.key[k]) < 0)
      end_wall_contact(s, walls, materials, contacts, k);
  });
  if (ended_log)
    for (std::size_t k = 0; k < contacts.size(); ++k)
      if (find_wall_contact(fresh, contacts.particle[k], contacts.key[k]) < 0)
        ended_log->push_back({contacts.key[k], true, contacts.work[k] - contacts.elastic[k]});
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
  resize_with_headroom(adjacency.pair_entry, start[particle_count]);
  // Contacts are sorted by (smaller id, larger id): walking them in order appends, for every
  // particle, first its smaller-id partners ascending, then its larger-id partners ascending.
  auto& cursor = adjacency.cursor;
  cursor.assign(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    adjacency.pair_entry[cursor[contacts.i[k]]++] = static_cast<std::uint32_t>(k << 1);
    adjacency.pair_entry[cursor[contacts.j[k]]++] = static_cast<std::uint32_t>((k << 1) | 1);
  }
  // A list in row order but not key order (slots not in id order): each particle's partners are
  // put in id order, so the gather sums them as it would with slots in id order.
  if (std::is_sorted(contacts.key.begin(), contacts.key.end())) return;
  const auto partner_id = [&](std::uint32_t entry) {
    const std::uint64_t key = contacts.key[entry >> 1];
    return (entry & 1) ? key >> 32 : key & 0xffffffffu;  // side 1: the particle is j, its partner i
  };
  parallel_for(particle_count, [&](std::size_t p) {
    std::sort(adjacency.pair_entry.begin() + start[p], adjacency.pair_entry.begin() + start[p + 1],
              [&](std::uint32_t a, std::uint32_t b) { return partner_id(a) < partner_id(b); });
  });
}

void permute_particles(PairContacts& c, const std::vector<std::uint32_t>& new_of_old, PairContacts& scratch) {
  const std::size_t n = new_of_old.size();
  // Each old row (a particle's contacts as i, ascending in key) becomes that particle's new row whole.
  std::vector<std::uint32_t> count(n, 0), start;
  for (std::size_t k = 0; k < c.size(); ++k) ++count[new_of_old[c.i[k]]];
  exclusive_scan(count, start);
  scratch.parts = c.parts;
  scratch.resize(c.size());
  count.assign(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < c.size(); ++k) {
    const std::uint32_t to = count[new_of_old[c.i[k]]]++;
    copy_pair(c, k, scratch, to);
    scratch.i[to] = new_of_old[c.i[k]];
    scratch.j[to] = new_of_old[c.j[k]];
  }
  scratch.row_start = std::move(start);
  c = scratch;  // into the list's own storage, which keeps its capacity
}

void permute_particles(WallContacts& c, const std::vector<std::uint32_t>& new_of_old, WallContacts& scratch) {
  const std::size_t n = new_of_old.size();
  std::vector<std::uint32_t> count(n, 0), start;
  for (std::size_t k = 0; k < c.size(); ++k) ++count[new_of_old[c.particle[k]]];
  exclusive_scan(count, start);
  scratch.resize(c.size());
  count.assign(start.begin(), start.end() - 1);
  for (std::size_t k = 0; k < c.size(); ++k) {
    const std::uint32_t to = count[new_of_old[c.particle[k]]]++;
    copy_wall(c, k, scratch, to);
    scratch.particle[to] = new_of_old[c.particle[k]];
  }
  c = scratch;
}

}  // namespace dem
