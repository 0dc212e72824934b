// Skin tracker (see skin.h).
// Reads: positions [m]. Writes: the reference positions (reset only).
// Threading: max reductions (broadphase/parallel.h); max is exact, so any split gives the same answer.
// NaN is made sticky explicitly, so a non-finite displacement is never hidden by the order of comparisons.
#include "broadphase/skin.h"

#include "broadphase/parallel.h"

#include <cmath>
#include <limits>

namespace dem::broadphase {
namespace {

// The larger of a and b, where a NaN on either side wins, so no split of the range can hide it.
double max_keep_nan(double a, double b) {
  if (std::isnan(a)) return a;
  if (std::isnan(b)) return b;
  return b > a ? b : a;
}

}  // namespace

void SkinTracker::reset(std::span<const Vec3> positions) {
  reference_.assign(positions.begin(), positions.end());
  has_reference_ = true;
}

double SkinTracker::max_displacement_sq(std::span<const Vec3> positions) const {
  if (!has_reference_ || positions.size() != reference_.size()) {
    return std::numeric_limits<double>::infinity();
  }
  return exact_reduce(
      positions.size(), 4096, 0.0,
      [&](std::size_t begin, std::size_t end, double m) {
        for (std::size_t i = begin; i < end; ++i) {
          m = max_keep_nan(m, (positions[i] - reference_[i]).squaredNorm());
        }
        return m;
      },
      max_keep_nan);
}

bool SkinTracker::needs_rebuild(std::span<const Vec3> positions, double skin) const {
  const double half = 0.5 * skin;
  return !(max_displacement_sq(positions) <= half * half);
}

double SkinTracker::max_displacement(std::span<const Vec3> positions) const {
  return std::sqrt(max_displacement_sq(positions));
}

}  // namespace dem::broadphase
