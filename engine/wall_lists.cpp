#include "engine/wall_lists.h"

#include <algorithm>

#include "engine/parallel.h"
#include "engine/types.h"

namespace dem {

static_assert(max_walls <= 0x10000, "wall indices are stored in 16 bits");

void WallLists::build(const State& s, const Walls& walls, Real margin) {
  const std::size_t n = s.size();
  const auto listed = [&](std::size_t p, std::size_t w) {
    return s.inv_mass[p] > 0 && walls.may_touch(w, s.position[p], s.radius[p], margin);
  };
  count_.resize(n);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t c = 0;
    for (std::size_t w = 0; w < walls.count(); ++w) c += listed(p, w) ? 1 : 0;
    count_[p] = c;
  });
  exclusive_scan(count_, start_);
  wall_.resize(start_[n]);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t k = start_[p];
    for (std::size_t w = 0; w < walls.count(); ++w)
      if (listed(p, w)) wall_[k++] = static_cast<std::uint16_t>(w);
  });
  reference_.assign(s.position.begin(), s.position.end());
  time_ = walls.time();
  margin_ = margin;
  built_ = true;
}

bool WallLists::valid(const State& s, const Walls& walls) const {
  if (!built_ || reference_.size() != s.size() || !(walls.time() >= time_)) return false;
  Real travel = 0;
  for (std::size_t w = 0; w < walls.count(); ++w) travel = std::max(travel, walls.max_travel(w, time_, walls.time()));
  const Real room = margin_ - travel;
  if (!(room >= 0)) return false;
  // Squared, so no root per particle; a NaN displacement fails the test too.
  return !parallel_any(s.size(), [&](std::size_t p) { return !((s.position[p] - reference_[p]).squaredNorm() <= room * room); });
}

std::size_t WallLists::memory_bytes() const {
  return start_.capacity() * sizeof(std::uint32_t) + wall_.capacity() * sizeof(std::uint16_t) +
         reference_.capacity() * sizeof(Vec3) + count_.capacity() * sizeof(std::uint32_t);
}

}  // namespace dem
