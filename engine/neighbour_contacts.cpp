#include "engine/neighbour_contacts.h"

#include <algorithm>

#include "engine/capacity.h"
#include "engine/checks.h"
#include "engine/parallel.h"
#include "engine/particle_kinds.h"

namespace dem {

void reset_neighbour(NeighbourContacts& nb, std::size_t k) {
  reset_pair_contact(nb.list, k);
  if (nb.list.parts.rolling) nb.list.rolling_torque[k].setZero();
  if (!nb.moment.empty()) nb.moment[k].setZero();
  nb.touching[k] = touching_no;
}

namespace {

// Row a lists the slots in which a is i; the slots in which p is j are collected here, walking the
// rows in id order (slot order while slots follow ids), so that they come by ascending id of their
// row and the gather sums every particle's contacts in partner id order.
void index_reverse_slots(const State& s, bool follow_ids, NeighbourContacts& nb) {
  const PairContacts& c = nb.list;
  const std::size_t n = s.size();
  std::vector<std::uint32_t>& cursor = nb.cursor;
  cursor.assign(n, 0);
  for (std::size_t k = 0; k < c.size(); ++k) ++cursor[c.j[k]];
  exclusive_scan(cursor, nb.reverse_start);
  resize_with_headroom(nb.reverse_slot, c.size());
  cursor.assign(nb.reverse_start.begin(), nb.reverse_start.end() - 1);
  const auto add_row = [&](std::size_t a) {
    for (std::uint32_t k = c.row_start[a]; k < c.row_start[a + 1]; ++k) nb.reverse_slot[cursor[c.j[k]]++] = k;
  };
  if (follow_ids) {
    for (std::size_t a = 0; a < n; ++a) add_row(a);
    return;
  }
  DEM_ASSERT(s.index_of_id.size() >= n);
  for (const ParticleIndex a : s.index_of_id)
    if (a != removed_slot) add_row(a);
}

}  // namespace

void orient_by_id(const State& s, const broadphase::CandidatePairs& by_slot, broadphase::CandidatePairs& by_id,
                  std::vector<std::uint32_t>& cursor) {
  const std::size_t n = by_slot.row_count();
  cursor.assign(n, 0);
  for (std::size_t a = 0; a < n; ++a)
    for (std::uint32_t k = by_slot.row_start[a]; k < by_slot.row_start[a + 1]; ++k)
      ++cursor[s.id[a] < s.id[by_slot.partner[k]] ? a : by_slot.partner[k]];
  exclusive_scan(cursor, by_id.row_start);
  resize_with_headroom(by_id.partner, by_slot.pair_count());
  cursor.assign(by_id.row_start.begin(), by_id.row_start.end() - 1);
  for (std::uint32_t a = 0; a < n; ++a)
    for (std::uint32_t k = by_slot.row_start[a]; k < by_slot.row_start[a + 1]; ++k) {
      const std::uint32_t b = by_slot.partner[k];
      if (s.id[a] < s.id[b])
        by_id.partner[cursor[a]++] = b;
      else
        by_id.partner[cursor[b]++] = a;
    }
  parallel_for(n, [&](std::size_t a) {
    const auto first = by_id.partner.begin() + by_id.row_start[a];
    const auto last = by_id.partner.begin() + by_id.row_start[a + 1];
    std::sort(first, last, [&](std::uint32_t p, std::uint32_t q) { return s.id[p] < s.id[q]; });
  });
}

void rebuild_neighbours(const State& s, const broadphase::CandidatePairs& by_slot, const PairContacts& contacts,
                        NeighbourContacts& nb) {
  const bool follow_ids = s.slots_follow_ids();
  if (!follow_ids) orient_by_id(s, by_slot, nb.oriented, nb.cursor);
  const broadphase::CandidatePairs& candidates = follow_ids ? by_slot : nb.oriented;
  const std::size_t n = candidates.row_count();
  const std::size_t m = candidates.pair_count();
  DEM_ASSERT(n == s.size() && contacts.row_start.size() == n + 1);
  PairContacts& list = nb.list;
  list.parts = contacts.parts;
  list.parts.keyed = false;
  list.resize(m);
  list.row_start = candidates.row_start;
  resize_with_headroom(nb.touching, m);
  // Torques need n x force only where contacts turn the particles (friction or rolling resistance).
  if (list.parts.friction || list.parts.rolling) resize_with_headroom(nb.moment, m);
  nb.row_ended.assign(n, 0);
  nb.row_has_ended.assign(n, 0);
  nb.row_deepest.assign(n, 0);
  nb.row_deepest_slot.assign(n, no_deepest_slot);
  assign_particle_kinds(s, nb.kind);
  nb.inherited.assign(contacts.size(), 0);
  // Row a holds the candidates (a, b) with id a < id b by ascending id b, so ascending in key, and so
  // are the contacts of row a in the compact list: a linear merge.
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t old = contacts.row_start[a];
    const std::uint32_t old_end = contacts.row_start[a + 1];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      DEM_ASSERT(s.id[a] < s.id[b]);
      list.j[k] = b;
      const std::uint64_t key = pair_key(s.id[a], s.id[b]);
      while (old < old_end && contacts.key[old] < key) ++old;
      reset_neighbour(nb, k);
      if (old < old_end && contacts.key[old] == key) {
        PairContacts::for_each_carried(list.parts, [&](auto field) { (list.*field)[k] = (contacts.*field)[old]; });
        // With its last force, so a list that reads the slots before its next evaluation has it all.
        if (list.parts.rolling) list.rolling_torque[k] = contacts.rolling_torque[old];
        nb.inherited[old] = 1;
        nb.touching[k] = touching_yes;
        ++old;
      }
    }
  });
  index_reverse_slots(s, follow_ids, nb);
  // The contacts left behind, by row (the compact list is in row order).
  nb.left_behind.clear();
  nb.left_key.clear();
  nb.left_dissipated.clear();
  nb.left_start.clear();
  for (std::uint32_t k = 0; k < contacts.size(); ++k) {
    if (nb.inherited[k]) continue;
    nb.left_behind.push_back(k);
    nb.left_key.push_back(contacts.key[k]);
    nb.left_dissipated.push_back(contacts.work[k] - contacts.elastic[k]);
  }
  if (nb.left_behind.empty()) return;
  nb.cursor.assign(n, 0);
  for (std::uint32_t k : nb.left_behind) ++nb.cursor[contacts.i[k]];
  exclusive_scan(nb.cursor, nb.left_start);
}

Real finish_ended_contacts(const State& s, NeighbourContacts& nb, const PairContacts& left_source,
                           ContactEvents* events, std::vector<EndedContact>* ended_log) {
  const std::size_t n = nb.row_has_ended.size();
  if (std::find(nb.row_has_ended.begin(), nb.row_has_ended.end(), 1) == nb.row_has_ended.end()) return 0;
  // Rows without an ended contact add +0, so this is update_pair_contacts' sum bit for bit.
  const Real ended = block_sum<Real>(n, [&](std::size_t a) { return nb.row_ended[a]; });
  PairContacts& c = nb.list;
  const bool left = !nb.left_start.empty();
  for (std::size_t a = 0; a < n; ++a) {
    if (!nb.row_has_ended[a]) continue;
    // The row's ended slots and left-behind contacts, in key order.
    std::uint32_t q = left ? nb.left_start[a] : 0;
    const std::uint32_t q_end = left ? nb.left_start[a + 1] : 0;
    const auto book_left_before = [&](std::uint64_t key) {
      for (; q < q_end && nb.left_key[q] < key; ++q) {
        const std::uint32_t k = nb.left_behind[q];
        if (events) events->record_pair(nb.left_key[q], left_source.history(k), left_source.work[k], left_source.elastic[k]);
        if (ended_log) ended_log->push_back({nb.left_key[q], false, nb.left_dissipated[q]});
      }
    };
    for (std::uint32_t k = c.row_start[a]; k < c.row_start[a + 1]; ++k) {
      if (nb.touching[k] != touching_ended) continue;
      const std::uint64_t key = pair_key(s.id[a], s.id[c.j[k]]);
      book_left_before(key);
      if (events) events->record_pair(key, c.history(k), c.work[k], c.elastic[k]);
      if (ended_log) ended_log->push_back({key, false, c.work[k] - c.elastic[k]});
      reset_neighbour(nb, k);
    }
    book_left_before(~std::uint64_t{0});
    nb.row_ended[a] = 0;
    nb.row_has_ended[a] = 0;
  }
  nb.left_behind.clear();
  nb.left_key.clear();
  nb.left_dissipated.clear();
  nb.left_start.clear();
  return ended;
}

void compact_touching(const State& s, const NeighbourContacts& nb, PairContacts& out, std::vector<std::uint32_t>& count) {
  const PairContacts& c = nb.list;
  const std::size_t n = c.row_start.size() - 1;
  count.resize(n);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t touching = 0;
    for (std::uint32_t k = c.row_start[a]; k < c.row_start[a + 1]; ++k) touching += nb.touching[k] == touching_yes;
    count[a] = touching;
  });
  exclusive_scan(count, out.row_start);
  out.parts = c.parts;
  out.parts.keyed = true;
  out.resize(out.row_start[n]);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t slot = out.row_start[a];
    for (std::uint32_t k = c.row_start[a]; k < c.row_start[a + 1]; ++k) {
      if (nb.touching[k] != touching_yes) continue;
      copy_pair(c, k, out, slot);  // the fields the slot holds
      out.i[slot] = static_cast<ParticleIndex>(a);
      out.key[slot] = pair_key(s.id[a], s.id[c.j[k]]);
      ++slot;
    }
  });
  DEM_VALIDATE(keys_ascend_along_rows(out));
}

}  // namespace dem
