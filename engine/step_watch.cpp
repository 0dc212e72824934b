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

}  // namespace

Worst deepest_contact(const State& s, const PairContacts& pairs, const WallContacts& walls) {
  const Worst pair = worst_of(pairs.size(), [&](std::size_t k) {
    const ParticleIndex i = pairs.i[k], j = pairs.j[k];
    return Worst{s.id[i], s.id[j], pairs.overlap[k] / std::min(s.radius[i], s.radius[j]), 0};
  });
  const Worst wall = worst_of(walls.size(), [&](std::size_t k) {
    const ParticleIndex p = walls.particle[k];
    return Worst{s.id[p], s.id[p], walls.overlap[k] / s.radius[p], 0};
  });
  return Worst::worse(pair, wall);
}

Worst longest_step_travel(const State& s, Real h) {
  return worst_of(s.size(), [&](std::size_t p) {
    return Worst{s.id[p], s.id[p], h * s.velocity[p].norm() / s.radius[p], 0};
  });
}

}  // namespace dem
