#include "engine/wall_lists.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "engine/parallel.h"
#include "engine/types.h"

namespace dem {

static_assert(max_walls <= 0x10000, "wall indices are stored in 16 bits");

void WallLists::build(const State& s, const Walls& walls, Real margin) {
  const std::size_t n = s.size();
  const auto listed = [&](std::size_t p, std::size_t w) {
    return s.inv_mass[p] > 0 && walls.may_touch(w, s.position[p], s.radius[p], margin);
  };
  // Counts go to start_[p + 1], then an inclusive scan in place turns them into row starts. Up to 64
  // walls, each particle's listed walls are kept as a bit mask by the counting pass, so every wall is
  // tested once; with more, the filling pass tests them again.
  const std::size_t wall_count = walls.count();
  const bool masks = wall_count <= 64;
  std::vector<std::uint64_t> mask(masks ? n : 0);
  start_.assign(n + 1, 0);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t c = 0;
    std::uint64_t m = 0;
    for (std::size_t w = 0; w < wall_count; ++w)
      if (listed(p, w)) {
        ++c;
        if (masks) m |= std::uint64_t{1} << w;
      }
    start_[p + 1] = c;
    if (masks) mask[p] = m;
  });
  listed_.clear();
  for (std::size_t p = 0; p < n; ++p) {
    if (start_[p + 1] > 0) listed_.push_back(static_cast<std::uint32_t>(p));
    start_[p + 1] += start_[p];
  }
  wall_.resize(start_[n]);
  parallel_for(n, [&](std::size_t p) {
    std::uint32_t k = start_[p];
    if (masks) {
      for (std::uint64_t m = mask[p]; m != 0; m &= m - 1) wall_[k++] = static_cast<std::uint16_t>(std::countr_zero(m));
      return;
    }
    for (std::size_t w = 0; w < wall_count; ++w)
      if (listed(p, w)) wall_[k++] = static_cast<std::uint16_t>(w);
  });
  reference_.resize(n);
  Real largest = 0;  // coordinate [m]
  for (std::size_t p = 0; p < n; ++p) {
    reference_[p] = s.position[p].cast<float>();
    largest = std::max(largest, s.position[p].cwiseAbs().maxCoeff());
  }
  // Each coordinate of the float copy is within half a float ulp of the true one, and so is the
  // displacement from it; taken off the margin so the test stays conservative.
  rounding_ = std::sqrt(3.0) * 0x1.0p-24 * largest;
  time_ = walls.time();
  margin_ = margin;
  built_ = true;
}

void WallLists::select(const WallLists& parent, const std::vector<std::uint32_t>& members) {
  built_ = parent.built_;
  if (!built_) return;
  const std::size_t n = members.size();
  start_.assign(n + 1, 0);
  wall_.clear();
  listed_.clear();
  reference_.resize(n);
  for (std::size_t q = 0; q < n; ++q) {
    const std::uint32_t p = members[q];
    wall_.insert(wall_.end(), parent.wall_.begin() + parent.start_[p], parent.wall_.begin() + parent.start_[p + 1]);
    start_[q + 1] = static_cast<std::uint32_t>(wall_.size());
    if (start_[q + 1] > start_[q]) listed_.push_back(static_cast<std::uint32_t>(q));
    reference_[q] = parent.reference_[p];
  }
  rounding_ = parent.rounding_;
  time_ = parent.time_;
  margin_ = parent.margin_;
}

bool WallLists::valid(const State& s, const Walls& walls) const {
  if (!built_ || reference_.size() != s.size() || !(walls.time() >= time_)) return false;
  Real travel = 0;
  for (std::size_t w = 0; w < walls.count(); ++w) travel = std::max(travel, walls.max_travel(w, time_, walls.time()));
  const Real room = margin_ - travel - rounding_;
  if (!(room >= 0)) return false;
  // Squared, so no root per particle; a NaN displacement fails the test too.
  return !parallel_any(s.size(), [&](std::size_t p) {
    return !((s.position[p] - reference_[p].cast<Real>()).squaredNorm() <= room * room);
  });
}

std::size_t WallLists::memory_bytes() const {
  return (start_.capacity() + listed_.capacity()) * sizeof(std::uint32_t) +
         wall_.capacity() * sizeof(std::uint16_t) + reference_.capacity() * sizeof(Eigen::Vector3f);
}

}  // namespace dem
