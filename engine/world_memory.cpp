// World::memory_breakdown: heap bytes by container group, counted by capacity (memory_usage.h).
// Groups follow the stages of an interval, so a figure points at the stage that holds the bytes.
#include <numeric>

#include "engine/doubling_work.h"
#include "engine/world.h"

namespace dem {
namespace {

std::size_t exact_bytes(const ExactWorkspace& w) {
  const ContactColoring& c = w.coloring;
  std::size_t high = heap_bytes(c.high_used);
  for (const auto& used : c.high_used) high += heap_bytes(used);
  return heap_bytes(w.interactions) + heap_bytes(w.count) + heap_bytes(w.offset) + heap_bytes(w.edge_i) +
         heap_bytes(w.edge_j) + heap_bytes(c.color_of) + heap_bytes(c.start) + heap_bytes(c.contact) +
         heap_bytes(c.low_mask) + high + heap_bytes(c.cursor) + heap_bytes(w.forced) + heap_bytes(w.saved_position) +
         heap_bytes(w.saved_velocity) + heap_bytes(w.saved_angular_velocity) + heap_bytes(w.history) +
         heap_bytes(w.events);
}

std::size_t island_bytes(const IslandState& s) {
  return heap_bytes(s.state) + heap_bytes(s.pairs) + heap_bytes(s.walls) + heap_bytes(s.adjacency) +
         heap_bytes(s.excursion) + heap_bytes(s.exact_history);
}

// Islands, their cut-out copies and the per-thread trials of step doubling.
std::size_t doubling_bytes(DoublingWork& d) {
  const Islands& is = d.islands;
  std::size_t total = heap_bytes(is.island_of) + heap_bytes(is.start) + heap_bytes(is.member) + heap_bytes(is.parent);
  total += heap_bytes(d.local_index) + heap_bytes(d.link_a) + heap_bytes(d.link_b) + heap_bytes(d.conflict_a) +
           heap_bytes(d.conflict_b) + heap_bytes(d.job_of) + heap_bytes(d.excursion) + heap_bytes(d.next);
  total += heap_bytes(d.jobs);
  for (const IslandJob& job : d.jobs) total += island_bytes(job.island) + heap_bytes(job.candidates);
  d.scratch.for_each([&](const IslandScratch& s) {
    total += heap_bytes(s.contacts) + exact_bytes(s.exact) + island_bytes(s.full) + island_bytes(s.half) +
             heap_bytes(s.origin) + s.levels_full.memory_bytes() + s.levels_half.memory_bytes() +
             s.retry.memory_bytes() + s.wall_lists.memory_bytes();
  });
  return total;
}

}  // namespace

std::vector<MemoryPart> World::memory_breakdown() const {
  std::vector<MemoryPart> parts;
  parts.push_back({"state", heap_bytes(state_)});
  parts.push_back({"skin reference", skin_tracker_.memory_bytes()});
  parts.push_back({"grid", grid_.memory_bytes()});
  parts.push_back({"k-d tree", kd_tree_.memory_bytes()});
  parts.push_back({"candidate pairs", heap_bytes(candidates_)});
  parts.push_back({"pair contacts", heap_bytes(pairs_) + heap_bytes(compact_scratch_)});
  parts.push_back({"persistent pair list", heap_bytes(neighbours_)});
  parts.push_back({"wall contacts", heap_bytes(wall_contacts_)});
  parts.push_back({"wall lists", wall_lists_.memory_bytes()});
  parts.push_back({"contact workspace", heap_bytes(workspace_)});
  parts.push_back({"adjacency", heap_bytes(adjacency_)});
  parts.push_back({"exact workspace", exact_bytes(exact_work_)});
  parts.push_back({"doubling", doubling_ ? doubling_bytes(*doubling_) : 0});
  return parts;
}

std::size_t World::memory_bytes() const {
  const std::vector<MemoryPart> parts = memory_breakdown();
  return std::accumulate(parts.begin(), parts.end(), std::size_t{0},
                         [](std::size_t sum, const MemoryPart& p) { return sum + p.bytes; });
}

}  // namespace dem
