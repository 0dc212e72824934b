#include "engine/memory_usage.h"

namespace dem {

std::size_t heap_bytes(const State& s) {
  return heap_bytes(s.id) + heap_bytes(s.position) + heap_bytes(s.velocity) + heap_bytes(s.angular_velocity) +
         heap_bytes(s.force) + heap_bytes(s.torque) + heap_bytes(s.radius) + heap_bytes(s.inv_mass) +
         heap_bytes(s.inv_inertia) + heap_bytes(s.material) + heap_bytes(s.level) + heap_bytes(s.index_of_id);
}

std::size_t heap_bytes(const PairContacts& c) {
  std::size_t total = heap_bytes(c.row_start);
  PairContacts::for_each_array(c.parts, [&](auto field) { total += heap_bytes(c.*field); });
  return total;
}

std::size_t heap_bytes(const WallContacts& c) {
  std::size_t total = 0;
  WallContacts::for_each_array([&](auto field) { total += heap_bytes(c.*field); });
  return total;
}

std::size_t heap_bytes(const ContactAdjacency& a) {
  return heap_bytes(a.pair_start) + heap_bytes(a.pair_entry) + heap_bytes(a.wall_start) + heap_bytes(a.cursor);
}

std::size_t heap_bytes(const ContactWorkspace& w) {
  return heap_bytes(w.count) + heap_bytes(w.offset) + heap_bytes(w.row_ended) + heap_bytes(w.key) +
         heap_bytes(w.source) + heap_bytes(w.carry) + heap_bytes(w.pairs) +
         heap_bytes(w.walls) + heap_bytes(w.found) + heap_bytes(w.wall_touch);
}

std::size_t heap_bytes(const broadphase::CandidatePairs& c) { return heap_bytes(c.row_start) + heap_bytes(c.partner); }

std::size_t heap_bytes(const NeighbourContacts& nb) {
  return heap_bytes(nb.list) + heap_bytes(nb.touching) + heap_bytes(nb.moment) + heap_bytes(nb.kind) +
         heap_bytes(nb.reverse_start) + heap_bytes(nb.reverse_slot) + heap_bytes(nb.row_ended) +
         heap_bytes(nb.row_has_ended) + heap_bytes(nb.row_deepest) + heap_bytes(nb.row_deepest_slot) +
         heap_bytes(nb.left_behind) + heap_bytes(nb.left_key) + heap_bytes(nb.left_dissipated) +
         heap_bytes(nb.left_start) + heap_bytes(nb.visited_rows) + heap_bytes(nb.inherited) + heap_bytes(nb.cursor);
}

}  // namespace dem
