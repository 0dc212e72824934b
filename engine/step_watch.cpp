#include "engine/step_watch.h"

#include <algorithm>
#include <cmath>
#include <tuple>

#include "engine/parallel.h"

namespace dem {

Worst Worst::worse(const Worst& a, const Worst& b) {
  if (std::isnan(a.value) != std::isnan(b.value)) return std::isnan(a.value) ? a : b;
  if (a.value != b.value) return a.value > b.value ? a : b;
  return std::tie(a.particle, a.partner) <= std::tie(b.particle, b.partner) ? a : b;
}

namespace {

template <class Ratio>
Worst worst_of(std::size_t n, const Ratio& ratio) {
  return exact_reduce(
      n, default_grain, Worst{},
      [&](std::size_t begin, std::size_t end, Worst acc) {
        for (std::size_t k = begin; k != end; ++k) {
          const Worst w = ratio(k);
          // Most entries are plainly smaller: only a larger, equal (ties go by id) or NaN one is merged.
          if (!(w.value < acc.value)) acc = Worst::worse(acc, w);
        }
        return acc;
      },
      &Worst::worse);
}

Worst deepest_wall_contact(const State& s, const WallContacts& walls) {
  return worst_of(walls.size(), [&](std::size_t k) {
    const ParticleIndex p = walls.particle[k];
    return Worst{s.id[p], s.id[p], walls.overlap[k] / s.radius[p], 0};
  });
}

}  // namespace

Worst deepest_contact(const State& s, const PairContacts& pairs, const WallContacts& walls) {
  const Worst pair = worst_of(pairs.size(), [&](std::size_t k) {
    const ParticleIndex i = pairs.i[k], j = pairs.j[k];
    return Worst{s.id[i], s.id[j], overlap_ratio(pairs.overlap[k], s.radius[i], s.radius[j]), 0};
  });
  return Worst::worse(pair, deepest_wall_contact(s, walls));
}

Worst deepest_contact(const State& s, const NeighbourContacts& nb, const WallContacts& walls) {
  // A row's deepest is its first slot of the largest ratio (a NaN before any number): partners
  // ascend along a row, so that is Worst::worse's choice among the row's contacts, and the choice
  // among rows is the same as among all contacts. A row without contacts holds 0 and no slot.
  const PairContacts& c = nb.list;
  const Worst pair = worst_of(nb.row_deepest.size(), [&](std::size_t a) {
    if (nb.row_deepest_slot[a] == no_deepest_slot) return Worst{};
    const std::uint32_t k = nb.row_deepest_slot[a];
    return Worst{s.id[a], s.id[c.j[k]], nb.row_deepest[a], 0};
  });
  return Worst::worse(pair, deepest_wall_contact(s, walls));
}

}  // namespace dem
